//! Equivocation is punished (issue #37, finding 6): a sealer that signs two blocks on one
//! parent stops sealing on the honest chain once the evidence is in a block, and the run that
//! does so replays bit-exactly (every record survives its encoding, and folding the events
//! re-makes every checkpoint). Written against the ledger's read API only, so the same test
//! runs on code without the punishment (there the equivocators keep sealing).

use swarmfl_core::byzantine::byzantine_robots;
use swarmfl_core::config::{ByzantineKind, Config, LedgerBehaviour, Preset};
use swarmfl_core::event::Record;
use swarmfl_core::sim::Sim;
use swarmfl_core::state::State;

#[test]
fn an_equivocating_sealer_stops_sealing_once_the_evidence_is_in_a_block() {
    let seed = 5;
    let mut config: Config = Preset::Smoke.config();
    config.run.duration_s = 1200.0;
    config.world.robots = 10;
    config.learn.lstm_units = 4;
    config.learn.epochs = 1;
    config.byzantine.count = 2;
    config.byzantine.kind = ByzantineKind::None;
    config.byzantine.ledger = LedgerBehaviour::Equivocate;
    // The world this test was written against (before #38 moved `paper`'s to the authors'
    // code): with robot occlusion and no random turns, 10 robots meet less and the evidence
    // reaches a block too late for 1200 s. The test is about the ledger, not the world.
    config.world.rab_robot_occlusion = false;
    config.world.random_turn_rate_per_s = 0.1;
    config.data.window_rule = swarmfl_core::config::WindowRule::Contiguous;
    config.world.avoidance = swarmfl_core::config::Avoidance::Turn;
    config.world.slide_on_contact = false;
    config.validate().expect("a valid configuration");
    let robots = config.world.robots;
    let byzantine = byzantine_robots(&config, seed);
    let honest: Vec<u32> = (0..robots).filter(|&r| !byzantine[r as usize]).collect();

    let mut state = State::genesis(&config, seed).expect("genesis");
    let mut sim = Sim::new(config, seed).expect("a run");
    let mut checkpoints = 0;
    for record in sim.by_ref() {
        let bytes = rmp_serde::to_vec(&record).expect("records encode");
        let decoded: Record = rmp_serde::from_slice(&bytes).expect("records decode");
        assert_eq!(decoded, record, "a record changes through its encoding");
        match record {
            Record::Event { time, event } => {
                state
                    .apply(time, &event)
                    .expect("the run's own events fold");
            }
            Record::Checkpoint(c) => {
                assert_eq!(
                    state.checkpoint(c.time, c.cause),
                    c,
                    "checkpoint {checkpoints}"
                );
                checkpoints += 1;
            }
        }
    }
    assert!(checkpoints > 50, "{checkpoints} checkpoints");

    let ledger = &sim.state().ledger;
    // The heaviest honest chain (ties to the lowest id).
    let reference = *honest
        .iter()
        .max_by_key(|&&r| (ledger.head_total_difficulty(r), std::cmp::Reverse(r)))
        .expect("honest robots");
    let chain = ledger.canonical_chain(reference);
    let mut punished = 0;
    for sealer in (0..robots).filter(|&r| byzantine[r as usize]) {
        // The lowest parent height on this chain at which an honest node saw the sealer sign
        // two blocks.
        let first = honest
            .iter()
            .flat_map(|&r| ledger.node(r).evidence().keys())
            .filter(|(s, _)| *s == sealer)
            .filter_map(|(_, parent)| {
                let height = ledger.block(parent)?.block.header.height;
                (chain.get(height as usize) == Some(parent)).then_some(height)
            })
            .min();
        let Some(first) = first else { continue };
        let signer_at = |h: usize| ledger.block(&chain[h]).expect("stored").block.header.signer;
        let before = (1..=first as usize + 1)
            .filter(|&h| signer_at(h) == sealer)
            .count();
        assert!(before > 0, "sealer {sealer} equivocated without sealing");
        // Room for the evidence to reach a block: three rotations of the swarm.
        let grace = first as usize + 1 + 3 * robots as usize;
        let after: Vec<usize> = (grace..chain.len())
            .filter(|&h| signer_at(h) == sealer)
            .collect();
        assert!(
            after.is_empty(),
            "sealer {sealer} equivocated on height {first} and still sealed heights {after:?} \
             of {} on the honest chain",
            chain.len() - 1
        );
        assert!(
            chain.len() > grace + 2 * robots as usize,
            "the run is too short to show that sealer {sealer} stopped"
        );
        punished += 1;
    }
    assert!(
        punished > 0,
        "no equivocation was detected on the honest chain"
    );
}
