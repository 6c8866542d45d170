//! The plug points' registries (`core/src/config/registry.rs`): each variant is one line of its
//! list, and each file of a plug point's folder is a registered variant. A line declares its
//! file (`Krum = "krum" in krum`), so a new rule, attack, pre-aggregator or ledger attack whose
//! file is there but whose line is not is not even compiled: it fails
//! [`every_plug_point_file_is_registered`], which names the file and the line to add.

use std::collections::BTreeSet;
use std::path::Path;

use swarmfl_core::config::{
    Behaviour, ByzantineKind, LedgerBehaviour, Preaggregator, Rule, Timing,
};

/// One plug point as the tests see it: its `ALL` as names and indices, its unlisted variants,
/// and its lookup.
struct PlugPoint {
    label: &'static str,
    /// `(name, index)` of each variant of `ALL`, in order.
    all: Vec<(&'static str, usize)>,
    /// Names of the variants left out of `ALL`.
    unlisted: Vec<&'static str>,
    /// The variant count the enum declares.
    count: usize,
    /// `from_name(name)` mapped back to its name.
    lookup: fn(&str) -> Option<&'static str>,
    /// The folder of its files (under `core/src`), with the files that are not variants, and
    /// the variants that need no file.
    folder: Option<(
        &'static str,
        &'static [&'static str],
        &'static [&'static str],
    )>,
}

macro_rules! plug_point {
    ($label:literal, $Enum:ident, [$($unlisted:expr),*], $folder:expr) => {
        PlugPoint {
            label: $label,
            all: $Enum::ALL.iter().map(|v| (v.name(), v.index())).collect(),
            unlisted: vec![$($unlisted.name()),*],
            count: $Enum::COUNT,
            lookup: |name| $Enum::from_name(name).map($Enum::name),
            folder: $folder,
        }
    };
}

fn plug_points() -> Vec<PlugPoint> {
    vec![
        plug_point!(
            "rule",
            Rule,
            [Rule::Plugin],
            Some(("contract/rules", &["mod"], &[]))
        ),
        plug_point!(
            "pre-aggregator",
            Preaggregator,
            [],
            Some(("contract/preagg", &["mod", "tests"], &[]))
        ),
        plug_point!(
            "attack",
            ByzantineKind,
            [],
            // `line_search` is the optimal attacks' shared search, `ledger/` the ledger attacks.
            Some(("byzantine", &["mod", "line_search"], &["none"]))
        ),
        plug_point!(
            "ledger attack",
            LedgerBehaviour,
            [],
            Some(("byzantine/ledger", &["mod", "tests"], &["honest"]))
        ),
        // Behaviours are controllers spread over `world/` (and `mixed` is a swarm of them):
        // no folder of one file each to compare with.
        plug_point!("behaviour", Behaviour, [], None),
        plug_point!(
            "timing model",
            Timing,
            [],
            Some(("sim/timing", &["mod", "tests"], &[]))
        ),
    ]
}

/// `multi-krum` as a variant's name, `MultiKrum`.
fn camel_case(name: &str) -> String {
    name.split('-')
        .map(|word| {
            let mut chars = word.chars();
            chars
                .next()
                .map(|c| c.to_ascii_uppercase().to_string() + chars.as_str())
                .unwrap_or_default()
        })
        .collect()
}

/// `ALL[i].index() == i`, every name once, every name parses back to itself, and `ALL` plus
/// the unlisted variants are every variant the enum has.
#[test]
fn each_registry_lists_every_variant_once_in_order() {
    for p in plug_points() {
        let mut seen = BTreeSet::new();
        for (i, &(name, index)) in p.all.iter().enumerate() {
            assert_eq!(index, i, "{} {name}: ALL[{i}] has index {index}", p.label);
            assert!(seen.insert(name), "{} {name} is listed twice", p.label);
        }
        for name in p
            .all
            .iter()
            .map(|&(n, _)| n)
            .chain(p.unlisted.iter().copied())
        {
            assert_eq!((p.lookup)(name), Some(name), "{} {name}", p.label);
        }
        assert_eq!(
            p.all.len() + p.unlisted.len(),
            p.count,
            "{}: ALL and the unlisted variants are not every variant",
            p.label
        );
        assert_eq!((p.lookup)("no-such-variant"), None, "{}", p.label);
    }
}

/// Each file of a plug point's folder names a registered variant (`multi_krum.rs` is
/// `multi-krum`), and each registered variant but the stated ones has its file.
#[test]
fn every_plug_point_file_is_registered() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    for p in plug_points() {
        let Some((folder, helpers, fileless)) = p.folder else {
            continue;
        };
        let mut files = BTreeSet::new();
        for entry in std::fs::read_dir(src.join(folder)).unwrap() {
            let path = entry.unwrap().path();
            let (Some(stem), Some("rs")) = (
                path.file_stem().and_then(|s| s.to_str()),
                path.extension().and_then(|s| s.to_str()),
            ) else {
                continue;
            };
            if !helpers.contains(&stem) {
                files.insert(stem.replace('_', "-"));
            }
        }
        for file in &files {
            let stem = file.replace('-', "_");
            assert!(
                (p.lookup)(file).is_some(),
                "core/src/{folder}/{stem}.rs is not a registered {label}, so it is not compiled: \
                 add its line `{variant} = \"{file}\" in {stem}` to the {label} registry \
                 (core/src/config/; the type `{stem}::{variant}` in the file implements the \
                 plug point's trait)",
                label = p.label,
                variant = camel_case(file),
            );
        }
        let names = p
            .all
            .iter()
            .map(|&(n, _)| n)
            .chain(p.unlisted.iter().copied());
        for name in names.filter(|n| !fileless.contains(n)) {
            assert!(
                files.contains(name),
                "the {} {name} has no file core/src/{folder}/{}.rs",
                p.label,
                name.replace('-', "_")
            );
        }
    }
}
