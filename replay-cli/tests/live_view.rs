//! `swarmfl run --live` (issue #35): the run's files are those of a run without it, the server
//! answers on the loopback address while the run goes and stops after it, and a port in use is
//! a clear error. The page itself (frames advancing in a browser, the words at the end, Ctrl-C)
//! is checked in headless Chromium by `scripts/view_check.sh` (`scripts/page_check.py live`).

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("swarmfl-live-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn smoke(out: &Path, extra: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_swarmfl"));
    c.args([
        "run", "--preset", "smoke", "--seed", "7", "--quiet", "--out",
    ])
    .arg(out)
    .args(extra);
    c
}

/// One `GET path` on 127.0.0.1:port: the status code and the body (HTTP/1.0: no chunks).
fn get(port: u16, path: &str) -> Option<(u16, String)> {
    let mut s = TcpStream::connect(("127.0.0.1", port)).ok()?;
    s.set_read_timeout(Some(Duration::from_secs(10))).ok()?;
    write!(s, "GET {path} HTTP/1.0\r\nHost: 127.0.0.1\r\n\r\n").ok()?;
    let mut text = String::new();
    s.read_to_string(&mut text).ok()?;
    let code = text.split_whitespace().nth(1)?.parse().ok()?;
    let body = text
        .split_once("\r\n\r\n")
        .map_or("", |(_, b)| b)
        .to_string();
    Some((code, body))
}

/// The summary without its wall-clock fields (the only ones two runs of one seed may differ in).
fn summary_without_wall_clock(dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("summary.json")).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let map = v.as_object_mut().unwrap();
    assert!(map.remove("wall_s").is_some() && map.remove("timing").is_some());
    v
}

#[test]
fn a_live_run_writes_the_same_log_and_summary_and_serves_only_while_it_goes() {
    let dir = scratch("same");
    let plain = dir.join("plain");
    let live = dir.join("live");
    assert!(smoke(&plain, &[]).status().unwrap().success());
    let mut child = smoke(&live, &["--live", "--port", "0"])
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut lines = BufReader::new(child.stderr.take().unwrap()).lines();
    let url_line = lines
        .by_ref()
        .map_while(Result::ok)
        .find(|l| l.starts_with("live view: "))
        .expect("the live run prints its URL");
    // Loopback only, as printed.
    let port: u16 = url_line
        .strip_prefix("live view: http://127.0.0.1:")
        .and_then(|rest| rest.split('/').next())
        .and_then(|p| p.parse().ok())
        .unwrap_or_else(|| panic!("not a loopback URL: {url_line}"));
    // The page and its data, while the run goes (or, at the latest, its last page).
    let started = Instant::now();
    let data = loop {
        match get(port, "/data.json") {
            Some((200, body)) => break body,
            Some((503, body)) => assert!(body.contains("starting"), "{body}"),
            other => panic!("the live server answered {other:?}"),
        }
        assert!(
            started.elapsed() < Duration::from_secs(60),
            "no data in 60 s"
        );
        std::thread::sleep(Duration::from_millis(100));
    };
    let data: serde_json::Value = serde_json::from_str(&data).unwrap();
    assert!(
        data["live"]["version"].as_u64().unwrap() >= 1,
        "{}",
        data["live"]
    );
    let (code, page) = get(port, "/").unwrap();
    assert_eq!(code, 200);
    assert!(page.contains("id=\"status\""), "{page}");
    assert_eq!(get(port, "/elsewhere").map(|(c, _)| c), Some(404));
    let status = child.wait().unwrap();
    let rest: Vec<String> = lines.map_while(Result::ok).collect();
    assert!(status.success(), "{rest:?}");
    // Stopped with the run.
    assert!(TcpStream::connect(("127.0.0.1", port)).is_err());
    assert_eq!(
        std::fs::read(plain.join("run.swlog")).unwrap(),
        std::fs::read(live.join("run.swlog")).unwrap(),
        "the log differs with --live"
    );
    let summary = summary_without_wall_clock(&live);
    assert_eq!(summary_without_wall_clock(&plain), summary);
    assert_eq!(
        summary["final_hash"],
        "b82e59177235ffb2dc04db924fc810b8a2fdd2f642b9537ed1c71dcfed0a62e1"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_port_in_use_is_named_with_the_way_out_and_nothing_is_written() {
    let dir = scratch("busy");
    let taken = TcpListener::bind(("127.0.0.1", 0)).unwrap();
    let port = taken.local_addr().unwrap().port().to_string();
    let out = smoke(&dir.join("run"), &["--live", "--port", &port])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains(&format!("port {port} on 127.0.0.1 is in use")),
        "{err}"
    );
    assert!(
        err.contains("--port N") && err.contains("--port 0"),
        "{err}"
    );
    assert!(!dir.join("run").exists(), "a refused live run wrote files");
    // --port alone is a mistake the parser names.
    let out = smoke(&dir.join("run"), &["--port", "9"]).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("--live"), "{err}");
    drop(taken);
    let _ = std::fs::remove_dir_all(&dir);
}
