use std::path::PathBuf;

use super::expr::{Env, EvalError, Expr};
use super::*;
use crate::config::{ByzantineKind, LedgerBehaviour, Preset};
use crate::log::{Header, LogWriter};
use crate::metrics;
use crate::replay::ReplayError;
use crate::sim::Sim;

/// A fixed environment: `a = 2`, `b = 3`, `nan`-valued `loss`, `balance[i] = 10 i`,
/// `node[i].height = 100 + i`, four robots.
struct Fixed;

impl Env for Fixed {
    fn ident(&self, name: &str) -> Result<f64, EvalError> {
        Ok(match name {
            "height" => 2.0,
            "round" => 3.0,
            "loss" => f64::NAN,
            "time" => 0.5,
            _ => 0.0,
        })
    }
    fn indexed(&self, _: &str, i: u32) -> Result<f64, EvalError> {
        if i < 4 {
            Ok(10.0 * f64::from(i))
        } else {
            Err(EvalError(format!("no robot {i}")))
        }
    }
    fn node(&self, i: u32, _: &str) -> Result<f64, EvalError> {
        Ok(100.0 + f64::from(i))
    }
}

/// `expect` is `Ok(value)` or `Err(column)` of the parse error.
fn check(src: &str, expect: Result<f64, usize>) {
    match (Expr::parse(src), expect) {
        (Ok(e), Ok(v)) => {
            let got = e.eval(&Fixed).unwrap();
            assert!(
                got == v || (got.is_nan() && v.is_nan()),
                "{src}: {got} != {v}"
            );
        }
        (Err(e), Err(column)) => {
            assert_eq!(e.column, column, "{src}: {e}");
            assert!(e.message.contains("expected"), "{src}: {e}");
        }
        (got, want) => panic!("{src}: got {got:?}, want {want:?}"),
    }
}

#[test]
fn expressions_parse_and_evaluate() {
    check("1 + 2 * 3", Ok(7.0));
    check("(1 + 2) * 3", Ok(9.0));
    check("10 - 4 - 3", Ok(3.0));
    check("8 / 4 / 2", Ok(1.0));
    check("-height + 1", Ok(-1.0));
    check("round >= 3", Ok(1.0));
    check("round > 3", Ok(0.0));
    check("height == 2 && round != 2", Ok(1.0));
    check("height < 1 || round <= 3", Ok(1.0));
    check("!(height < 1)", Ok(1.0));
    check("!!round", Ok(1.0));
    check("loss > 0.1", Ok(0.0));
    check("loss <= 0.1", Ok(0.0));
    check("!(loss > 0.1)", Ok(1.0));
    check("balance[3] - balance[1]", Ok(20.0));
    check("node[3].height + 5 < node[0].height", Ok(0.0));
    check("node[0].height + 5 > node[3].height", Ok(1.0));
    check("1.5e2 + time", Ok(150.5));
    check("2e-1 * 10", Ok(2.0));
    check("1 / 0 > 1000", Ok(1.0));
    // Errors: the column of the offending token, and what was expected.
    check("", Err(1));
    check("height >", Err(9));
    check("height > > 2", Err(10));
    check("(height", Err(8));
    check("height )", Err(8));
    check("heigth > 2", Err(1));
    check("1 < 2 < 3", Err(7));
    check("balance > 2", Err(9));
    check("balance[x]", Err(9));
    check("balance[1.5]", Err(9));
    check("node[1]", Err(8));
    check("node[1].weight", Err(9));
    check("round = 3", Err(7));
    check("round & 3", Err(7));
    check("1e", Err(3));
    check("height[0]", Err(1));
}

#[test]
fn parse_errors_say_what_was_expected_and_show_the_column() {
    let e = Expr::parse("round >= ").unwrap_err();
    assert!(e.message.contains("found the end of the expression"), "{e}");
    let text = e.to_string();
    assert!(text.contains("column 10"), "{text}");
    assert!(text.ends_with("         ^"), "{text:?}");
    let e = Expr::parse("byzantine_token > 1").unwrap_err();
    assert!(
        e.message.contains("byzantine_tokens"),
        "lists the identifiers: {e}"
    );
}

#[test]
fn deep_or_long_expressions_are_refused_with_the_column_not_a_stack_overflow() {
    use super::expr::{MAX_DEPTH, MAX_LEN_BYTES};
    // At the limit: accepted.
    let at = format!("{}1{}", "(".repeat(MAX_DEPTH), ")".repeat(MAX_DEPTH));
    check(&at, Ok(1.0));
    check(&format!("{}1", "!".repeat(MAX_DEPTH)), Ok(1.0));
    check(&format!("{}1", "-".repeat(MAX_DEPTH)), Ok(1.0));
    // One deeper: refused at the offending token's column.
    let over = format!(
        "{}1{}",
        "(".repeat(MAX_DEPTH + 1),
        ")".repeat(MAX_DEPTH + 1)
    );
    check(&over, Err(MAX_DEPTH + 1));
    check(
        &format!("{}1", "!".repeat(MAX_DEPTH + 1)),
        Err(MAX_DEPTH + 1),
    );
    let mixed = format!("{}1{}", "!(-".repeat(50), ")".repeat(50));
    let e = Expr::parse(&mixed).unwrap_err();
    assert_eq!(e.column, MAX_DEPTH + 1, "{e}");
    assert!(
        e.to_string().contains(&format!(
            "at column {}: expression nests deeper than {MAX_DEPTH}",
            MAX_DEPTH + 1
        )),
        "{e}"
    );
    // The inputs of the security review: far beyond both limits, refused by length.
    for src in [
        format!("{}1{}", "(".repeat(5000), ")".repeat(5000)),
        format!("{}1", "!".repeat(40_000)),
    ] {
        let e = Expr::parse(&src).unwrap_err();
        assert_eq!(e.column, MAX_LEN_BYTES + 1, "{}", e.message);
        assert!(
            e.message.contains(&format!(
                "{} bytes long; expected at most {MAX_LEN_BYTES}",
                src.len()
            )),
            "{}",
            e.message
        );
    }
    // A long but shallow expression within the limit still parses.
    let sum = format!("1{}", " + 1".repeat((MAX_LEN_BYTES - 1) / 4));
    assert!(sum.len() <= MAX_LEN_BYTES);
    check(&sum, Ok(((MAX_LEN_BYTES - 1) / 4 + 1) as f64));
}

#[test]
fn eval_errors_name_the_robot() {
    let e = Expr::parse("balance[7] > 1").unwrap();
    assert!(e.eval(&Fixed).is_err());
    let leaves = Expr::parse("round > 1 && balance[2] > round")
        .unwrap()
        .leaves(&Fixed);
    assert_eq!(
        leaves,
        vec![("round".to_string(), 3.0), ("balance[2]".to_string(), 20.0)]
    );
}

/// A short run with security on and three smart robots, written to a temporary log.
fn short_run(name: &str) -> PathBuf {
    short_run_with(name, |_| {})
}

/// [`short_run`] with `tweak` applied to its configuration.
fn short_run_with(name: &str, tweak: impl FnOnce(&mut crate::config::Config)) -> PathBuf {
    let mut config = Preset::Smoke.config();
    tweak(&mut config);
    config.run.duration_s = 200.0;
    config.contract.security = true;
    config.byzantine.kind = ByzantineKind::Smart;
    config.byzantine.count = 3;
    config.validate().unwrap();
    let dir = std::env::temp_dir().join(format!("swarmfl-inspect-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("run.swlog");
    let header = Header::new(2, config.to_toml());
    let mut writer = LogWriter::create(&path, &header).unwrap();
    for record in Sim::new(config, 2).unwrap() {
        writer.append(&record).unwrap();
    }
    writer.finish().unwrap();
    path
}

/// Two equivocators in a swarm of 10 (the equivocation test's scenario, 300 s, seed 3): each
/// twin comes by injection, with no sealing checkpoint, and the twin at height 2 ends up on the
/// final canonical chain. The old index refused the whole log ("canonical block 80ba6d8b5b622d5b
/// at height 2 has no sealing checkpoint"), so no block of it could be inspected.
#[test]
fn a_log_whose_canonical_chain_holds_an_equivocators_twin_is_inspected() {
    let mut config = Preset::Smoke.config();
    config.run.duration_s = 300.0;
    config.world.robots = 10;
    config.learn.lstm_units = 4;
    config.learn.epochs = 1;
    config.byzantine.count = 2;
    config.byzantine.kind = ByzantineKind::None;
    config.byzantine.ledger = LedgerBehaviour::Equivocate;
    config.validate().unwrap();
    let seed = 3;
    let dir = std::env::temp_dir().join(format!("swarmfl-inspect-{}-twin", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("run.swlog");
    let mut writer = LogWriter::create(&path, &Header::new(seed, config.to_toml())).unwrap();
    for record in Sim::new(config, seed).unwrap() {
        writer.append(&record).unwrap();
    }
    writer.finish().unwrap();

    let index = index_run(&path, None).unwrap();
    // Which canonical blocks were stored by an injection: their record is not a checkpoint.
    let mut kinds = Vec::new();
    let mut reader = crate::log::LogReader::open(&path).unwrap();
    while let Some(record) = reader.next_record().unwrap() {
        kinds.push(matches!(record, crate::event::Record::Checkpoint(_)));
    }
    let twins: Vec<u64> = index
        .chain
        .iter()
        .filter(|row| row.record.is_some_and(|i| !kinds[i as usize]))
        .map(|row| row.height)
        .collect();
    assert!(
        twins.contains(&2),
        "the scenario puts a twin on the canonical chain: {twins:?}"
    );
    let byzantine = crate::byzantine::byzantine_robots(&index.config, seed);
    for (h, row) in index.chain.iter().enumerate().skip(2) {
        assert!(row.record > index.chain[h - 1].record, "records increase");
    }
    let sidecar = index.sidecar(&path).unwrap();
    for &h in &twins {
        let at = index_run(&path, Some(h)).unwrap();
        let report = block_report(&at, h, None).unwrap();
        assert_eq!(report.block.hash, index.chain[h as usize].hash.to_hex());
        let signer = report.block.signer.unwrap();
        assert!(byzantine[signer as usize], "a twin is an equivocator's");
        // The state kept is the one right after the injection stored it, as the sidecar's fold
        // up to that record gives it.
        let indexed = block_report_indexed(&path, &sidecar, h, None).unwrap();
        assert_eq!(
            serde_json::to_string(&report).unwrap(),
            serde_json::to_string(&indexed).unwrap(),
            "block {h}"
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn blocks_are_found_inspected_and_bisected() {
    let path = short_run("blocks");
    let index = index_run(&path, None).unwrap();
    let last = index.last_height();
    assert!(last >= 5, "the run seals blocks: {last}");
    // The chain is the best node's, row h is at height h, records and times increase.
    let best = metrics::best_node(&index.final_state.ledger);
    let chain = index.final_state.ledger.canonical_chain(best);
    assert_eq!(chain.len(), index.chain.len());
    for (h, row) in index.chain.iter().enumerate() {
        assert_eq!((row.height, row.hash), (h as u64, chain[h]));
        if h > 1 {
            assert!(row.record > index.chain[h - 1].record);
            assert!(row.time >= index.chain[h - 1].time);
        }
    }

    // Inspecting a block: the state kept is the one right after its sealing, i.e. the same
    // state as folding the log up to its checkpoint.
    let h = last / 2;
    let at = index_run(&path, Some(h)).unwrap();
    let report = block_report(&at, h, Some(1)).unwrap();
    assert_eq!(report.block.height, h);
    assert_eq!(report.block.hash, index.chain[h as usize].hash.to_hex());
    let (state, _) = at.at_block.as_ref().unwrap();
    let (folded, _, _) = crate::replay::state_at_time(&path, index.chain[h as usize].time).unwrap();
    let sealed_at = index.chain[h as usize].time;
    assert!(state.world.time() >= sealed_at && state.world.time().0 < sealed_at.0 + 100);
    assert_eq!(
        state.world.digest(),
        folded.world.digest(),
        "same tick, same world"
    );
    let signer = report.block.signer.unwrap();
    assert_eq!(
        report.nodes[signer as usize].height, h,
        "the signer's head is the block"
    );
    assert!(report.nodes[signer as usize].on_final_chain);
    assert_eq!(report.robot.as_ref().unwrap().robot, 1);
    assert_eq!(report.contract.balances.len(), 15);
    assert_eq!(
        report
            .contract
            .balances
            .iter()
            .filter(|b| b.byzantine)
            .count(),
        3
    );
    // The sidecar index gives the same report by folding only up to the block.
    assert!(read_sidecar(&path).is_none(), "no sidecar yet");
    let sidecar = at.sidecar(&path).unwrap();
    std::fs::write(
        sidecar_path(&path),
        serde_json::to_string(&sidecar).unwrap(),
    )
    .unwrap();
    let sidecar = read_sidecar(&path).expect("a fresh sidecar fits its log");
    for (height, robot) in [(h, Some(1)), (0, None), (last, Some(14))] {
        let full = index_run(&path, Some(height)).unwrap();
        let a = serde_json::to_string(&block_report(&full, height, robot).unwrap()).unwrap();
        let b =
            serde_json::to_string(&block_report_indexed(&path, &sidecar, height, robot).unwrap())
                .unwrap();
        assert_eq!(a, b, "block {height}");
    }
    assert!(matches!(
        block_report_indexed(&path, &sidecar, last + 1, None),
        Err(InspectError::BlockPastEnd { .. })
    ));
    let genesis = index_run(&path, Some(0)).unwrap();
    assert_eq!(block_report(&genesis, 0, None).unwrap().block.signer, None);

    // Errors: past the end names the last height; a robot out of the swarm.
    match index_run(&path, Some(last + 1)) {
        Err(InspectError::BlockPastEnd { block, last: l, .. }) => {
            assert_eq!((block, l), (last + 1, last))
        }
        other => panic!("expected BlockPastEnd, got {:?}", other.err()),
    }
    assert!(matches!(
        block_report(&at, h, Some(15)),
        Err(InspectError::NoRobot {
            robot: 15,
            robots: 15
        })
    ));

    // Bisect: the scan and the binary search agree on monotone predicates.
    let values = index.values();
    for src in [
        "height >= 3",
        "time > 100",
        "round >= 1",
        "node[0].height >= 4",
        "byzantine_tokens > honest_tokens",
        "byzantine_wealth > honest_wealth",
        "!(pool < 0)",
        "height > 100000",
    ] {
        let e = Expr::parse(src).unwrap();
        let truth: Vec<bool> = (0..values.len() as u64)
            .map(|h| e.holds(&values.at(h)).unwrap())
            .collect();
        let monotone = truth.windows(2).all(|w| w[1] || !w[0]);
        let prof = profile(&values, &e).unwrap();
        assert_eq!(prof.monotone, monotone, "{src}");
        assert_eq!(prof.first, truth.iter().position(|&t| t).map(|h| h as u64));
        if let Some(g) = prof.for_good_from {
            assert!(truth[g as usize..].iter().all(|&t| t));
            assert!(g == 0 || !truth[g as usize - 1]);
        }
        let scan = bisect(&values, &e, false).unwrap();
        let binary = bisect(&values, &e, true).unwrap();
        assert_eq!(
            scan.as_ref().map(|h| h.height),
            truth.iter().position(|&t| t).map(|h| h as u64),
            "{src}"
        );
        if monotone {
            assert_eq!(
                scan.as_ref().map(|h| h.height),
                binary.as_ref().map(|h| h.height),
                "{src}"
            );
            if let (Some(s), Some(b)) = (&scan, &binary) {
                assert!(b.evaluations <= 2 + 64 - (values.len() as u64).leading_zeros() as u64);
                assert_eq!(s.values, b.values, "{src}");
            }
        } else if let Some(b) = &binary {
            // Not monotone here: the binary search still lands on a change to true.
            let h = b.height as usize;
            assert!(truth[h] && (h == 0 || !truth[h - 1]), "{src}");
        }
    }
    let hit = bisect(&values, &Expr::parse("height >= 3").unwrap(), false)
        .unwrap()
        .unwrap();
    assert_eq!((hit.height, hit.evaluations), (3, 4));
    assert_eq!(hit.values, vec![("height".to_string(), 3.0)]);
    assert!(bisect(&values, &Expr::parse("balance[99] > 0").unwrap(), false).is_err());

    // The rounds of the chain close in order.
    let rounds = index.rounds();
    for w in rounds.windows(2) {
        assert_eq!(w[1].round, w[0].round + 1);
        assert!(w[1].block > w[0].block);
    }
    // One numbering everywhere: the first round is round 1 (the summary's r1), and at the
    // block that closes round k, bisect's `round` is k and `loss` is that round's loss.
    assert_eq!(rounds.first().map(|r| r.round), Some(1), "{rounds:?}");
    for r in &rounds {
        let at = values.at(r.block);
        assert_eq!(at.ident("round").unwrap(), r.round as f64);
        let loss = at.ident("loss").unwrap();
        assert!(loss == r.loss || (loss.is_nan() && r.loss.is_nan()));
    }

    // A log of another format version: a clear error naming both versions, no panic.
    let mut bytes = std::fs::read(&path).unwrap();
    bytes[8..12].copy_from_slice(&(crate::log::FORMAT_VERSION + 1).to_le_bytes());
    let other = path.with_file_name("other-version.swlog");
    std::fs::write(&other, &bytes).unwrap();
    std::fs::write(
        sidecar_path(&other),
        serde_json::to_string(&sidecar).unwrap(),
    )
    .unwrap();
    assert!(read_sidecar(&other).is_some(), "same size and footer");
    assert!(block_report_indexed(&other, &sidecar, 1, None).is_err());
    let mut cut = bytes.clone();
    cut.pop();
    std::fs::write(&other, &cut).unwrap();
    assert!(
        read_sidecar(&other).is_none(),
        "a changed log makes its sidecar stale"
    );
    std::fs::write(&other, &bytes).unwrap();
    let e = index_run(&other, Some(1))
        .err()
        .expect("another version is refused");
    assert!(
        matches!(
            e,
            InspectError::Replay(ReplayError::Log(crate::log::LogError::Version { .. }))
        ),
        "{e}"
    );
    assert!(e.to_string().contains("format version"), "{e}");

    // A truncated log: indexed on its intact prefix, saying so; every block it still has is
    // the same block as in the whole log.
    let full = std::fs::read(&path).unwrap();
    let cut_path = path.with_file_name("cut.swlog");
    std::fs::write(&cut_path, &full[..full.len() * 2 / 3]).unwrap();
    let cut = index_run(&cut_path, None).expect("the intact prefix is indexed");
    let why = cut.truncated.as_deref().expect("says it is truncated");
    assert!(why.contains("truncated"), "{why}");
    assert!(
        cut.last_height() >= 1 && cut.last_height() < last,
        "{}",
        cut.last_height()
    );
    assert!(cut.records < index.records);
    // (The tip of the prefix may still be reorganised later: compare its older half.)
    for row in &cut.chain[..cut.chain.len() / 2] {
        let whole = &index.chain[row.height as usize];
        assert_eq!(
            (row.hash, row.time),
            (whole.hash, whole.time),
            "block {}",
            row.height
        );
    }
    let report = block_report(&index_run(&cut_path, Some(1)).unwrap(), 1, None).unwrap();
    assert_eq!(report.block.height, 1);
    assert!(index.truncated.is_none());
    std::fs::remove_dir_all(path.parent().unwrap()).unwrap();
}

/// A short smoke run of `aggregation` (no Byzantine robots), written to a temporary log.
fn baseline_run(
    name: &str,
    aggregation: crate::config::Aggregation,
) -> (PathBuf, crate::config::Config) {
    let mut config = Preset::Smoke.config();
    config.run.duration_s = 200.0;
    config.learn.aggregation = aggregation;
    config.validate().unwrap();
    let dir = std::env::temp_dir().join(format!("swarmfl-tables-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("run.swlog");
    let header = Header::new(3, config.to_toml());
    let mut writer = LogWriter::create(&path, &header).unwrap();
    for record in Sim::new(config.clone(), 3).unwrap() {
        writer.append(&record).unwrap();
    }
    writer.finish().unwrap();
    (path, config)
}

fn u64s<'a>(t: &'a Table, name: &str) -> &'a [u64] {
    match t.column(name) {
        Some(Column::U64(v)) => v,
        other => panic!("{name}: {other:?}"),
    }
}

fn f64s<'a>(t: &'a Table, name: &str) -> &'a [f64] {
    match t.column(name) {
        Some(Column::F64(v)) => v,
        other => panic!("{name}: {other:?}"),
    }
}

fn same(a: f64, b: f64) -> bool {
    a == b || (a.is_nan() && b.is_nan())
}

#[test]
fn chain_tables_agree_with_the_rounds_and_conserve_tokens() {
    let path = short_run("tables");
    let index = index_run(&path, None).unwrap();
    let rounds = index.rounds_table().unwrap();
    let rows = index.rounds();
    assert!(rows.len() >= 2, "the run closes rounds: {}", rows.len());
    assert_eq!(rounds.rows(), rows.len());
    assert_eq!(
        u64s(&rounds, "round"),
        rows.iter().map(|r| r.round).collect::<Vec<_>>()
    );
    // Every closed round's counted submissions, as many accepted and outliers as the round's row.
    let subs = index.submissions_table().unwrap();
    let (sub_round, outcome) = (
        u64s(&subs, "round"),
        match subs.column("outcome") {
            Some(Column::Str(v)) => v.clone(),
            other => panic!("{other:?}"),
        },
    );
    for r in &rows {
        let of = |what: &str| {
            sub_round
                .iter()
                .zip(&outcome)
                .filter(|(&n, o)| n == r.round && o.as_str() == what)
                .count() as u64
        };
        assert_eq!(
            (of("accepted"), of("outlier")),
            (r.accepted, r.outliers),
            "round {}",
            r.round
        );
    }
    let robots = u64s(&subs, "robot");
    let byz = match subs.column("byzantine") {
        Some(Column::Bool(v)) => v,
        other => panic!("{other:?}"),
    };
    for (r, b) in robots.iter().zip(byz) {
        assert_eq!(*b, index.byzantine[*r as usize]);
    }
    assert!(byz.iter().any(|&b| b), "the smart robots submit");
    let reward: f64 = f64s(&subs, "reward_tokens").iter().sum();
    assert!(reward > 0.0, "security is on: rounds pay");
    // Balances: one row per robot per block; with the contract's holdings they sum to the
    // robots' initial tokens at every block.
    let balances = index.balances_table().unwrap();
    let n = index.config.world.robots as usize;
    assert_eq!(balances.rows(), index.chain.len() * n);
    let tokens = f64s(&balances, "balance_tokens");
    for (h, block) in tokens.chunks(n).enumerate() {
        let held = index.tokens(index.contract_at(h as u64).holdings_units);
        let total: f64 = block.iter().sum::<f64>() + held;
        let expect = index.tokens(index.contract_at(0).balances.iter().sum::<u64>());
        assert!(
            (total - expect).abs() < 1e-6,
            "block {h}: {total} != {expect}"
        );
    }
    let chain_bytes = index.chain_bytes_table().unwrap();
    assert_eq!(chain_bytes.rows(), index.chain_bytes.len() * n);
}

#[test]
fn baseline_rounds_are_its_aggregations_and_chain_tables_say_why_not() {
    let (path, config) = baseline_run("gossip", crate::config::Aggregation::Gossip);
    let index = index_run(&path, None).unwrap();
    let rounds = index.rounds_table().unwrap();
    let (contract, _) = crate::aggregation::summary::summarise(
        &config,
        &index.final_state.aggregation,
        &index.final_state.metrics,
        index.final_state.world.heldout(),
        &index.byzantine,
    );
    assert!(contract.rounds > 0, "the gossip run aggregates");
    assert_eq!(
        rounds.rows() as u64,
        contract.rounds,
        "as many rows as summary.json's rounds"
    );
    for (a, b) in f64s(&rounds, "loss").iter().zip(&contract.loss_by_round) {
        assert!(same(*a, *b));
    }
    for (a, b) in f64s(&rounds, "time_s").iter().zip(&contract.round_times_s) {
        assert!(same(*a, *b));
    }
    for table in [
        index.submissions_table(),
        index.balances_table(),
        index.chain_bytes_table(),
    ] {
        let e = table.unwrap_err().to_string();
        assert!(
            e.contains("a gossip run has no") && e.contains("learn.aggregation"),
            "{e}"
        );
    }
}

#[test]
fn poses_are_sampled_at_the_rate_asked() {
    let (path, config) = baseline_run("poses", crate::config::Aggregation::Central);
    let t = poses_table(&path, 10.0).unwrap();
    let n = config.world.robots as usize;
    let times = f64s(&t, "time_s");
    assert_eq!(t.rows() % n, 0);
    let samples: Vec<f64> = times.chunks(n).map(|c| c[0]).collect();
    assert_eq!(samples[0], 0.0);
    for w in samples.windows(2) {
        assert!((w[1] - w[0] - 10.0).abs() < 0.15, "{w:?}");
    }
    assert!(samples.len() >= 20, "200 s at 10 s: {}", samples.len());
    // The last sample is the state the full replay reaches at that time.
    let last = *samples.last().unwrap();
    let (state, _, _) =
        crate::replay::state_at_time(&path, crate::types::SimTime((last * 1000.0) as u64)).unwrap();
    let xs = f64s(&t, "x");
    assert_eq!(
        &xs[xs.len() - n..],
        state.world.poses().iter().map(|p| p.x).collect::<Vec<_>>()
    );
    for bad in [0.0, -1.0, f64::NAN] {
        let e = poses_table(&path, bad).unwrap_err().to_string();
        assert!(e.contains("positive number of seconds"), "{e}");
    }
}

/// What an index says, as text (its state by the digests of a checkpoint).
fn index_text(index: &RunIndex) -> String {
    let digests = index.final_state.checkpoint(
        crate::types::SimTime(0),
        crate::event::CheckpointCause::Periodic,
    );
    format!(
        "{:?} {:?} {} {:?} {:?} {:?} {digests:?} {}",
        index.chain,
        index.chain_bytes,
        index.records,
        index.byzantine,
        index.truncated,
        index.at_block.as_ref().map(|(s, l)| (
            s.checkpoint(
                crate::types::SimTime(0),
                crate::event::CheckpointCause::Periodic
            ),
            l
        )),
        index.config.run.duration_s
    )
}

#[test]
fn an_indexer_fed_in_pieces_gives_the_index_of_each_prefix() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../fixtures/logs/short-resim-seed7.swlog");
    let bytes = std::fs::read(&path).unwrap();
    let dir = std::env::temp_dir().join(format!("swarmfl-indexer-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let cut_path = dir.join("cut.swlog");
    let name = path.display().to_string();
    let mut reader = crate::log::LogReader::open(&path).unwrap();
    let mut indexer = Indexer::start(&reader, &name, Some(1)).unwrap();
    let mut taken = 0;
    while let Some(record) = reader.next_record().unwrap() {
        indexer.feed(reader.index() - 1, &record).unwrap();
        // Every 97th record (and the first) a snapshot, compared with the index of a file
        // holding just the records so far (block 1 asked for, once it exists).
        let at = reader.index();
        if at % 97 != 1 {
            continue;
        }
        std::fs::write(&cut_path, &bytes[..reader.offset() as usize]).unwrap();
        match index_run(&cut_path, Some(1)) {
            Ok(mut cut) => {
                let snap = indexer.index(cut.truncated.clone()).unwrap();
                cut.path = snap.path.clone();
                assert_eq!(index_text(snap), index_text(&cut), "after record {at}");
                taken += 1;
            }
            Err(InspectError::BlockPastEnd { .. }) => {
                let snap = indexer.index(Some("cut".into()));
                assert!(matches!(snap, Err(InspectError::BlockPastEnd { .. })));
            }
            Err(e) => panic!("{e}"),
        }
    }
    assert!(taken > 5, "{taken} snapshots");
    let whole = index_run(&path, Some(1)).unwrap();
    assert_eq!(
        index_text(&indexer.finish(None).unwrap()),
        index_text(&whole)
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_seeker_keeps_a_snapshot_every_k_blocks_and_starts_later_lookups_there() {
    let path = short_run_with("seek", |c| c.output.snapshot_every_blocks = 4);
    let index = index_run(&path, None).unwrap();
    assert!(index.last_height() >= 9, "{}", index.last_height());
    let record = |h: u64| index.chain[h as usize].record.unwrap();
    let text = |r: BlockReport| serde_json::to_string(&r).unwrap();
    let mut seeker = Seeker::new(&path, index.sidecar(&path).unwrap()).unwrap();
    // The first lookup folds from genesis and keeps blocks 4 and 8 on the way.
    let at_9 = seeker.block_report(9, Some(1)).unwrap();
    assert_eq!(seeker.last_folded(), record(9) + 1);
    assert_eq!(seeker.snapshots(), 2);
    // Later ones start from the nearest snapshot at or before their block.
    let at_6 = seeker.block_report(6, None).unwrap();
    assert_eq!(seeker.last_folded(), record(6) - record(4));
    let at_8 = seeker.block_report(8, Some(2)).unwrap();
    assert_eq!(seeker.last_folded(), 0);
    let at_2 = seeker.block_report(2, None).unwrap();
    assert_eq!(seeker.last_folded(), record(2) + 1);
    let at_0 = seeker.block_report(0, None).unwrap();
    assert_eq!(seeker.last_folded(), 0);
    assert_eq!(seeker.snapshots(), 2);
    // Each report is the one of a fold from genesis.
    for (h, robot, got) in [
        (9, Some(1), at_9),
        (6, None, at_6),
        (8, Some(2), at_8),
        (2, None, at_2),
        (0, None, at_0),
    ] {
        let full = index_run(&path, Some(h)).unwrap();
        assert_eq!(
            text(block_report(&full, h, robot).unwrap()),
            text(got),
            "block {h}"
        );
    }
    // Blocks past the end are refused by name.
    assert!(matches!(
        seeker.block_report(index.last_height() + 1, None),
        Err(InspectError::BlockPastEnd { .. })
    ));
    std::fs::remove_dir_all(path.parent().unwrap()).unwrap();
}
