//! The README says what its commands print; these tests run them and compare (issue #53).
//!
//! The README is parsed, not copied: the tour is the first fenced block under "## A tour of
//! the CLI", one command a line with its claim in a trailing `# comment`. A line the tests do not
//! recognise is left alone, so the tour can be edited freely; a line they recognise must print
//! what its comment says:
//! - `swarmfl presets`: the comment lists every preset `swarmfl presets` prints, in its order;
//! - `swarmfl run ... --out DIR  # writes A and B`: the run writes A and B;
//! - `swarmfl bisect LOG --until P  # ... block N (t = T s) ..., closing round R; warns: not
//!   monotone`: bisect finds block N at T s, prints `round = R`, and warns that P is not
//!   monotone exactly when the comment says so (the run that wrote LOG is the tour's line with
//!   `--out` its folder, run first);
//! - `swarmfl export LOG --out DIR  # a.csv, b.csv`: the export writes exactly those files.
//!
//! Every line's subcommand must also be one `swarmfl` knows. The runs are the tour's smoke
//! runs (about a second each in a release build), made in a temporary folder that stands for the
//! folder the user types the commands in.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// One command of the tour.
#[derive(Debug)]
struct TourLine {
    /// 1-based line number in README.md.
    number: usize,
    /// The arguments after `swarmfl`, quotes removed, `[--optional]` groups left out.
    args: Vec<String>,
    /// The text after the `#` that ends the command ("" if none).
    comment: String,
}

impl TourLine {
    /// The value after `flag`, if the line has it.
    fn value_of(&self, flag: &str) -> Option<&str> {
        let at = self.args.iter().position(|a| a == flag)?;
        self.args.get(at + 1).map(String::as_str)
    }

    fn is(&self, subcommand: &str) -> bool {
        self.args.first().is_some_and(|a| a == subcommand)
    }
}

fn readme() -> String {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../README.md");
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// The lines of the tour's fenced block.
fn tour() -> Vec<TourLine> {
    let text = readme();
    let mut lines = text.lines().enumerate();
    lines
        .by_ref()
        .find(|(_, l)| l.starts_with("## A tour of the CLI"))
        .expect("README.md has a section \"## A tour of the CLI\"");
    lines
        .by_ref()
        .take_while(|(_, l)| !l.starts_with("## "))
        .find(|(_, l)| l.starts_with("```"))
        .expect("the tour section has a fenced block");
    let tour: Vec<TourLine> = lines
        .take_while(|(_, l)| !l.starts_with("```"))
        .filter_map(|(i, l)| parse_line(i + 1, l))
        .collect();
    assert!(
        tour.len() > 10,
        "README.md's tour has {} commands",
        tour.len()
    );
    tour
}

/// A tour line `swarmfl ARGS  # comment`, split as a shell would (quotes), without the
/// optional `[--flag value]` groups.
fn parse_line(number: usize, line: &str) -> Option<TourLine> {
    let mut words: Vec<String> = Vec::new();
    let mut word: Option<String> = None;
    let mut quote: Option<char> = None;
    let mut optional = false;
    let mut comment = String::new();
    let mut chars = line.char_indices().peekable();
    while let Some((at, c)) = chars.next() {
        match (quote, c) {
            (Some(q), c) if c == q => quote = None,
            (Some(_), c) => word.get_or_insert_default().push(c),
            (None, '\'' | '"') => {
                quote = Some(c);
                word.get_or_insert_default();
            }
            (None, '#') if word.is_none() => {
                comment = line[at + 1..].trim().to_owned();
                break;
            }
            (None, '[') if word.is_none() && chars.peek().is_some_and(|&(_, n)| n == '-') => {
                optional = true;
            }
            (None, c) if c.is_whitespace() => {
                if let Some(w) = word.take().filter(|_| !optional) {
                    words.push(w);
                }
            }
            (None, ']') if optional => {
                word = None;
                optional = false;
            }
            (None, c) => word.get_or_insert_default().push(c),
        }
    }
    if let Some(w) = word.filter(|_| !optional) {
        words.push(w);
    }
    if words.first().map(String::as_str) != Some("swarmfl") {
        return None;
    }
    words.remove(0);
    Some(TourLine {
        number,
        args: words,
        comment,
    })
}

/// A fresh folder of this test process under the system's temporary folder.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("swarmfl-tour-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("a temporary folder");
    dir
}

/// `swarmfl ARGS` in folder `dir`, as the user would type it there.
fn swarmfl_in(dir: &Path, args: &[String]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_swarmfl"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("running swarmfl")
}

/// Runs a tour line in `dir` and returns its standard output and error; it must succeed.
fn run_line(dir: &Path, line: &TourLine) -> (String, String) {
    let out = swarmfl_in(dir, &line.args);
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(
        out.status.success(),
        "README.md:{}: `swarmfl {}` failed ({}):\n{stderr}",
        line.number,
        line.args.join(" "),
        out.status
    );
    (stdout, stderr)
}

/// The first number that follows `word ` in `text` (`block 28`, `round 5`, `t = 100 s` with
/// word `t =`); an occurrence not followed by a number (`block where`) is passed over.
fn number_after(text: &str, word: &str) -> Option<f64> {
    let word = format!("{word} ");
    text.match_indices(&word).find_map(|(at, _)| {
        let digits: String = text[at + word.len()..]
            .chars()
            .take_while(|c| c.is_ascii_digit() || *c == '.')
            .collect();
        digits.trim_end_matches('.').parse().ok()
    })
}

#[test]
fn the_tours_preset_list_is_what_presets_prints() {
    let tour = tour();
    let line = tour
        .iter()
        .find(|l| l.args == ["presets"])
        .expect("the tour shows `swarmfl presets`");
    let claimed: Vec<&str> = line.comment.split(',').map(str::trim).collect();
    let (printed, _) = run_line(&std::env::temp_dir(), line);
    let presets: Vec<&str> = printed
        .lines()
        .filter_map(|l| l.split_whitespace().next())
        .collect();
    assert_eq!(
        claimed, presets,
        "README.md:{}: the comment of `swarmfl presets` should list the presets it prints",
        line.number
    );
}

#[test]
fn every_tour_line_names_a_subcommand_swarmfl_has() {
    let dir = std::env::temp_dir();
    for line in tour() {
        let subcommand = line.args.first().expect("a subcommand after swarmfl");
        let out = swarmfl_in(&dir, &[subcommand.clone(), "--help".into()]);
        assert!(
            out.status.success(),
            "README.md:{}: `swarmfl {subcommand}` is not a command of swarmfl:\n{}",
            line.number,
            String::from_utf8_lossy(&out.stderr)
        );
    }
}

#[test]
fn the_tours_runs_bisects_and_export_print_what_their_comments_say() {
    let tour = tour();
    let dir = scratch("claims");
    let mut ran: Vec<String> = Vec::new();
    // The run that writes the log at `log`: the tour's line whose `--out` is its folder.
    let mut ensure_run = |log: &str| {
        let folder = Path::new(log)
            .parent()
            .and_then(Path::to_str)
            .expect("a log in a folder");
        if ran.iter().any(|r| r == folder) {
            return;
        }
        let line = tour
            .iter()
            .find(|l| l.is("run") && l.value_of("--out") == Some(folder))
            .unwrap_or_else(|| {
                panic!("the tour uses {log} but has no `swarmfl run ... --out {folder}`")
            });
        run_line(&dir, line);
        if let Some(written) = line.comment.strip_prefix("writes ") {
            for file in written.split(" and ").map(str::trim) {
                assert!(
                    dir.join(file).is_file(),
                    "README.md:{}: the run should write {file}",
                    line.number
                );
            }
        }
        ran.push(folder.to_owned());
    };

    let mut bisects = 0;
    for line in tour.iter().filter(|l| l.is("bisect")) {
        ensure_run(&line.args[1]);
        let (stdout, stderr) = run_line(&dir, line);
        let printed = format!("{stdout}{stderr}");
        let here = format!(
            "README.md:{}: `swarmfl {}`",
            line.number,
            line.args.join(" ")
        );
        let found = stdout
            .lines()
            .find(|l| l.starts_with("first block where"))
            .unwrap_or_else(|| panic!("{here} printed no block:\n{printed}"));
        let block = number_after(&line.comment, "block")
            .unwrap_or_else(|| panic!("{here}: its comment names no `block N`"));
        assert_eq!(
            number_after(found, "height"),
            Some(block),
            "{here}:\n{printed}"
        );
        if let Some(t_s) = number_after(&line.comment, "t =") {
            assert_eq!(number_after(found, "t ="), Some(t_s), "{here}:\n{printed}");
        }
        if let Some(round) = number_after(&line.comment, "round") {
            assert!(
                printed.contains(&format!("round = {round}\n")),
                "{here}: should close round {round}:\n{printed}"
            );
        }
        let warns = printed.contains("NOT monotone");
        assert_eq!(
            warns,
            line.comment.contains("not monotone"),
            "{here}: the comment and the warning disagree on whether the predicate is monotone:\n{printed}"
        );
        bisects += 1;
    }
    assert!(bisects >= 1, "the tour shows no `swarmfl bisect`");

    let export = tour
        .iter()
        .find(|l| l.is("export"))
        .expect("the tour shows `swarmfl export`");
    ensure_run(&export.args[1]);
    run_line(&dir, export);
    let out = dir.join(export.value_of("--out").expect("export --out"));
    let mut written: Vec<String> = std::fs::read_dir(&out)
        .unwrap_or_else(|e| panic!("{}: {e}", out.display()))
        .map(|e| {
            e.expect("an entry")
                .file_name()
                .to_string_lossy()
                .into_owned()
        })
        .collect();
    written.sort();
    let mut claimed: Vec<String> = export
        .comment
        .split(',')
        .map(|f| f.trim().to_owned())
        .collect();
    claimed.sort();
    assert_eq!(
        claimed, written,
        "README.md:{}: the files `swarmfl export` writes",
        export.number
    );
    std::fs::remove_dir_all(&dir).expect("the temporary folder");
}

#[test]
fn parsing_a_tour_line() {
    let line = parse_line(
        7,
        r#"swarmfl bisect runs/s7/run.swlog --until "round >= 5" [--monotone]   # block 28, closing round 5"#,
    )
    .expect("a command");
    assert_eq!(
        line.args,
        ["bisect", "runs/s7/run.swlog", "--until", "round >= 5"]
    );
    assert_eq!(line.comment, "block 28, closing round 5");
    let line =
        parse_line(8, "swarmfl inspect L --block 40 [--robot 3] [--json] # x").expect("a command");
    assert_eq!(line.args, ["inspect", "L", "--block", "40"]);
    let line = parse_line(
        9,
        r#"swarmfl run --set 'faults.partitions=[{kind="split", start_s=1, end_s=2}]'  # cut"#,
    )
    .expect("a command");
    assert_eq!(
        line.args,
        [
            "run",
            "--set",
            r#"faults.partitions=[{kind="split", start_s=1, end_s=2}]"#
        ]
    );
    assert_eq!(number_after("block 8 (t = 80 s); warns", "t ="), Some(80.0));
    assert_eq!(
        number_after("height 10 at t = 100.000 s", "t ="),
        Some(100.0)
    );
    assert!(parse_line(10, "cargo run -- run").is_none());
}
