//! `swarmfl run --live`: the viewer of `swarmfl view`, served on the loopback address while the
//! run goes, its frames following the log as it grows.
//!
//! Two threads beside the run, and neither touches it: they only read the log file, which the
//! run flushes every [`swarmfl_study::run::Flush`] interval, so the log and the summary are the bytes of
//! a run without `--live`.
//! - The builder folds the log's intact prefix into the viewer's data with the code of
//!   `swarmfl view` (a [`Fold`] kept between builds: each build reads and folds only the
//!   records the log gained since the last, then makes the page of all of them, the same
//!   data as one fold of that prefix), numbering each build (its version). It builds again
//!   [`POLL_MS`] after the last build, or twice as long as that build took if longer, so the
//!   view never takes more than a third of one core from the run however long the log grows.
//!   When the run ends it builds once more from the finished log: that page says the run ended.
//! - The server ([`http`]: std::net, synchronous, one request per connection, bounded request
//!   heads, the loopback `Host` only) answers `GET /` with the page and `GET /data.json?have=V`
//!   with the newest data (or `{"unchanged":true}` when the page holds version V already).
//!   The page asks every [`POLL_MS`]. After the last build the server keeps
//!   answering while pages still ask (at most [`LINGER`]), so an open page learns that the run
//!   ended, then stops; Ctrl-C ends the process, server included, and an open page says the
//!   server is gone.

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use swarmfl_study::view::{Fold, LiveState, Page};

pub mod http;

use http::{Request, Response, Server};

/// How often the page asks for newer data, and the shortest time between two builds (ms).
pub const POLL_MS: u64 = 1000;

/// The longest the server answers after the run's last build, while pages still ask.
pub const LINGER: Duration = Duration::from_secs(5);

/// A page that has not asked for this long after the last build is taken as gone (or as
/// having seen the end: it stops asking then).
const QUIET_AFTER_END: Duration = Duration::from_millis(2 * POLL_MS);

/// The server bound to its port, before the run starts.
pub struct Bound {
    server: Server,
    port: u16,
}

/// The running live view: [`Live::finish`] it when the run has ended.
pub struct Live {
    shared: Arc<Shared>,
    port: u16,
    builder: JoinHandle<()>,
    server: JoinHandle<()>,
}

/// What the builder, the server and the run share.
struct Shared {
    /// The newest build, if any build has succeeded yet.
    page: Mutex<Option<Arc<Built>>>,
    /// The run has ended (set by [`Live::finish`]).
    run_ended: AtomicBool,
    /// The builder has published its last build (from the finished log).
    built_last: AtomicBool,
    /// The last time a page asked for anything.
    last_request: Mutex<Instant>,
}

/// One build, ready to serve.
struct Built {
    version: u64,
    html: String,
    data: String,
}

impl Live {
    /// Binds the live view to `127.0.0.1:port` (`0`: any free port). A port in use is an error
    /// that names it and the way out.
    pub fn bind(port: u16) -> anyhow::Result<Bound> {
        let server = Server::bind(port).map_err(|e| {
            if e.kind() == std::io::ErrorKind::AddrInUse {
                anyhow::anyhow!(
                    "--live: port {port} on 127.0.0.1 is in use (another `swarmfl run --live`, \
                     or another program); choose a free one with --port N, or --port 0 for \
                     any free port (the URL is printed)"
                )
            } else {
                anyhow::anyhow!("--live: cannot serve on 127.0.0.1:{port}: {e}; try --port 0")
            }
        })?;
        let port = server.port().unwrap_or(port);
        Ok(Bound { server, port })
    }

    /// The page's address.
    pub fn url(&self) -> String {
        format!("http://127.0.0.1:{}/", self.port)
    }

    /// Called when the run has ended (or failed): the builder makes its last page from the
    /// log as it is, the server answers while pages still ask (at most [`LINGER`]), then both
    /// stop.
    pub fn finish(self) {
        self.shared.run_ended.store(true, Ordering::SeqCst);
        // A thread that panicked has nothing left to stop; the run's result stands.
        let _ = self.builder.join();
        let _ = self.server.join();
    }
}

impl Bound {
    /// Starts the builder (reading `log` as the run writes it) and the server.
    pub fn start(self, log: &Path) -> Live {
        let shared = Arc::new(Shared {
            page: Mutex::new(None),
            run_ended: AtomicBool::new(false),
            built_last: AtomicBool::new(false),
            last_request: Mutex::new(Instant::now()),
        });
        let builder = {
            let shared = Arc::clone(&shared);
            let log = log.to_path_buf();
            std::thread::spawn(move || build_loop(&shared, &log))
        };
        let server = {
            let shared = Arc::clone(&shared);
            let server = self.server;
            std::thread::spawn(move || serve_loop(&shared, &server))
        };
        Live {
            shared,
            port: self.port,
            builder,
            server,
        }
    }
}

/// The builder: a page from the log's intact prefix every [`POLL_MS`] (or twice the last
/// build's time), and a last one from the finished log.
fn build_loop(shared: &Shared, log: &Path) {
    let mut version = 0;
    // Each successful build's wall time and the log's size it read, for the closing line.
    let mut updates: Vec<(Duration, u64)> = Vec::new();
    // The fold of the log so far, kept between updates (opened once the header is on disk).
    let mut fold: Option<Fold> = None;
    loop {
        // Read before the build: a run that ends during it gets one more build.
        let ended = shared.run_ended.load(Ordering::SeqCst);
        let started = Instant::now();
        let live = LiveState {
            version: version + 1,
            ended,
            poll_ms: POLL_MS,
        };
        let log_bytes = std::fs::metadata(log).map_or(0, |m| m.len());
        match update(&mut fold, log, live) {
            Ok(page) => {
                version += 1;
                let built = Built {
                    version,
                    html: page.html(),
                    data: page.data,
                };
                *lock(&shared.page) = Some(Arc::new(built));
                updates.push((started.elapsed(), log_bytes));
            }
            // Until the header is on disk the log cannot be read: the page says the run is
            // starting. A run that failed before writing anything leaves nothing to show.
            // A fold that failed is dropped: the next update starts again from the header.
            Err(e) => {
                fold = None;
                if ended {
                    eprintln!("live view: the log cannot be shown: {e:#}");
                }
            }
        }
        if ended {
            shared.built_last.store(true, Ordering::SeqCst);
            if let Some(line) = update_summary(&updates) {
                eprintln!("{line}");
            }
            return;
        }
        let wait = Duration::from_millis(POLL_MS).max(started.elapsed() * 2);
        let until = started + wait;
        while Instant::now() < until && !shared.run_ended.load(Ordering::SeqCst) {
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

/// One update: folds what the log gained since the last one (opening it first if need be)
/// and makes the page of everything folded.
fn update(fold: &mut Option<Fold>, log: &Path, live: LiveState) -> anyhow::Result<Page> {
    let fold = match fold {
        Some(fold) => fold,
        None => fold.insert(Fold::open(log)?),
    };
    fold.advance()?;
    fold.page(Some(live))
}

/// The closing line of a live view: how many page updates the run had and what one cost (wall
/// time, the log's size read), so a long run shows whether an update grows with its log.
fn update_summary(updates: &[(Duration, u64)]) -> Option<String> {
    let (first, last) = (updates.first()?, updates.last()?);
    let mut times: Vec<Duration> = updates.iter().map(|u| u.0).collect();
    times.sort();
    let median = times[times.len() / 2];
    let ms = |d: Duration| d.as_secs_f64() * 1000.0;
    let mb = |b: u64| b as f64 / 1.0e6;
    Some(format!(
        "live view: {} page updates, each from the log so far: first {:.0} ms ({:.1} MB of \
         log), median {:.0} ms, last {:.0} ms ({:.1} MB)",
        updates.len(),
        ms(first.0),
        mb(first.1),
        ms(median),
        ms(last.0),
        mb(last.1)
    ))
}

/// The server: answers until the last build has been published and no page asked for
/// [`QUIET_AFTER_END`] (at most [`LINGER`] after that build).
fn serve_loop(shared: &Shared, server: &Server) {
    let mut last_built_at: Option<Instant> = None;
    loop {
        let served = server.serve_one(Duration::from_millis(100), |request| {
            *lock(&shared.last_request) = Instant::now();
            answer(shared, request)
        });
        if let Err(e) = served {
            eprintln!("live view: the server stopped: {e}");
            return;
        }
        if shared.built_last.load(Ordering::SeqCst) {
            let at = *last_built_at.get_or_insert_with(Instant::now);
            let asked = *lock(&shared.last_request);
            let quiet = asked.elapsed() >= QUIET_AFTER_END && at.elapsed() >= QUIET_AFTER_END / 2;
            if quiet || at.elapsed() >= LINGER {
                return;
            }
        }
    }
}

/// The page shown before the first build (the run's first records are not on disk yet).
const STARTING: &str = "<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\">\
    <meta http-equiv=\"refresh\" content=\"1\"><title>swarmfl live: starting</title></head>\
    <body><p>The run is starting; this page reloads itself.</p>\
    <pre id=\"status\">{\"ok\":false,\"loading\":true,\"live\":{\"starting\":true}}</pre></body></html>";

/// Answers one request: `/` the page, `/data.json?have=V` the newest data, else 404 (whose
/// words do not repeat the path asked for).
fn answer(shared: &Shared, request: &Request) -> Response {
    let page = lock(&shared.page).clone();
    let (status, content_type, body) = match (request.path.as_str(), page) {
        ("/" | "/index.html", Some(page)) => (200, "text/html; charset=utf-8", page.html.clone()),
        ("/" | "/index.html", None) => (200, "text/html; charset=utf-8", STARTING.to_string()),
        ("/data.json", Some(page)) => {
            let have = request
                .query
                .split('&')
                .find_map(|kv| kv.strip_prefix("have="))
                .and_then(|v| v.parse::<u64>().ok());
            if have == Some(page.version) {
                (200, "application/json", "{\"unchanged\":true}".to_string())
            } else {
                (200, "application/json", page.data.clone())
            }
        }
        ("/data.json", None) => (503, "application/json", "{\"starting\":true}".to_string()),
        _ => (
            404,
            "text/plain; charset=utf-8",
            "no such page here: the live view is at /".to_string(),
        ),
    };
    Response {
        status,
        content_type,
        body,
    }
}

/// Locks a mutex whose holder may have panicked (the data is still whole: every writer
/// replaces it in one assignment).
fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::{Read, Write};
    use std::net::TcpStream;

    /// Sends `request` to 127.0.0.1:port (then closes the sending side) and reads the answer:
    /// its status and its whole text.
    fn exchange(port: u16, request: &[u8]) -> (u16, String) {
        let mut s = TcpStream::connect(("127.0.0.1", port)).unwrap();
        s.set_read_timeout(Some(Duration::from_secs(30))).unwrap();
        // The server may refuse before it has read it all: a failed write is its answer.
        let _ = s.write_all(request);
        let _ = s.shutdown(std::net::Shutdown::Write);
        let mut answer = Vec::new();
        let _ = s.read_to_end(&mut answer);
        let text = String::from_utf8_lossy(&answer).into_owned();
        let status = text
            .split_whitespace()
            .nth(1)
            .and_then(|c| c.parse().ok())
            .unwrap_or(0);
        (status, text)
    }

    #[test]
    fn the_server_bounds_requests_echoes_nothing_and_answers_its_loopback_host_only() {
        let bound = Live::bind(0).unwrap();
        let port = bound.port;
        let live = bound.start(Path::new("/nonexistent/swarmfl-live-test/run.swlog"));
        let get = |target: &str, host: &str| {
            exchange(
                port,
                format!("GET {target} HTTP/1.1\r\nHost: {host}\r\n\r\n").as_bytes(),
            )
        };
        // A long address: refused without reading it all, and not repeated.
        let long = format!("/{}", "a".repeat(200_000));
        let (status, text) = get(&long, "127.0.0.1");
        assert_eq!(status, 414, "{}", &text[..text.len().min(300)]);
        assert!(!text.contains("aaaa"), "the path is echoed");
        // Long headers.
        let big = format!(
            "GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Big: {}\r\n\r\n",
            "b".repeat(200_000)
        );
        let (status, text) = exchange(port, big.as_bytes());
        assert_eq!(status, 431, "{}", &text[..text.len().min(300)]);
        assert!(!text.contains("bbbb"));
        // An unknown path is not repeated.
        let (status, text) = get("/no-such-secret-path", "127.0.0.1");
        assert_eq!(status, 404, "{text}");
        assert!(!text.contains("no-such-secret-path"), "{text}");
        // A foreign host (a DNS rebinding) is refused; the loopback names are served.
        for host in ["evil.example", &format!("evil.example:{port}")] {
            let (status, text) = get("/", host);
            assert_eq!(status, 403, "{host}: {text}");
            assert!(!text.contains("evil"), "{text}");
        }
        for host in [
            format!("127.0.0.1:{port}"),
            format!("localhost:{port}"),
            format!("[::1]:{port}"),
        ] {
            let (status, text) = get("/", &host);
            assert_eq!(status, 200, "{host}: {text}");
            assert!(text.contains("The run is starting"), "{text}");
        }
        live.finish();
    }

    #[test]
    fn the_closing_line_gives_first_median_and_last_update() {
        assert_eq!(update_summary(&[]), None);
        let ms = Duration::from_millis;
        let line = update_summary(&[
            (ms(40), 1_000_000),
            (ms(90), 2_000_000),
            (ms(60), 3_000_000),
            (ms(300), 12_500_000),
        ])
        .unwrap();
        assert_eq!(
            line,
            "live view: 4 page updates, each from the log so far: first 40 ms (1.0 MB of log), \
             median 90 ms, last 300 ms (12.5 MB)"
        );
    }
}
