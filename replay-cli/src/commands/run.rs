//! `swarmfl run`: simulate a run into `DIR/run.swlog` and `DIR/summary.json` (the run itself
//! is [`swarmfl_study::run`]), then print its summary and what to try next.

use std::process::ExitCode;
use std::time::Duration;

use anyhow::Context;
use swarmfl_study::run::{density_warning, run_header, Flush, RunRequest};
use swarmfl_study::run_dir;

use crate::cli::RunArgs;
use crate::progress::Bar;
use crate::summary::{print_next, print_summary};

/// Runs `swarmfl run`: the run into `--out` (default [`run_dir::default_run_dir`]: distinct
/// per configuration), then its summary and what to try next unless `--quiet`. A run already in
/// the folder is replaced or refused as [`run_dir::prepare`] says.
pub fn command(args: RunArgs) -> anyhow::Result<ExitCode> {
    let RunArgs {
        config: config_args,
        seed,
        out,
        force,
        quiet,
        live,
        port,
    } = args;
    let config = config_args.resolve()?;
    let (out, chosen) = run_dir::choose(out, force, || {
        // The file was read once by `resolve`; a second read that fails says so.
        let file = match &config_args.config {
            Some(path) => Some(
                std::fs::read(path)
                    .with_context(|| format!("cannot read --config {}", path.display()))?,
            ),
            None => None,
        };
        Ok(run_dir::default_run_dir(
            &config.preset,
            seed,
            &config_args.overrides,
            file.as_deref(),
        ))
    })?;
    if let Some(warning) = density_warning(&config) {
        eprintln!("{warning}");
    }
    // Bound before the previous run is cleared: a port in use changes nothing on disk.
    let server = match live {
        true => Some(crate::live::Live::bind(port)?),
        false => None,
    };
    if let Some(replaced) = run_dir::prepare(&out, &run_header(&config, seed), chosen)? {
        eprintln!("{replaced}");
    }
    let outcome = match server {
        None => RunRequest::new(config, seed, &out).run(&Bar::new(quiet))?,
        Some(server) => {
            let live = server.start(&out.join("run.swlog"));
            eprintln!(
                "live view: {} (while the run goes; Ctrl-C stops the run and the view)",
                live.url()
            );
            let outcome = RunRequest::new(config, seed, &out)
                .flush(LIVE_FLUSH)
                .run(&Bar::new(quiet));
            // Whether the run ended or failed, the page gets the log as it is and says so.
            live.finish();
            outcome?
        }
    };
    if !quiet {
        print_summary(&outcome);
        print_next(&outcome);
    }
    Ok(ExitCode::SUCCESS)
}

/// How far behind the run the live view's reader of the log may fall: the log is flushed at
/// the first record after this much wall time.
const LIVE_FLUSH: Flush = Flush::Every(Duration::from_millis(250));
