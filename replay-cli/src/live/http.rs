//! The live view's HTTP/1.1 server, on `std::net` alone and bounded everywhere: one request per
//! connection (`Connection: close`), answered on the server's thread.
//!
//! - The request head (request line and headers) is read through a reader that stops at
//!   [`MAX_HEAD_BYTES`]: a longer request line is refused with 414, a longer head with 431,
//!   before more of it is read, so a request of any size costs at most that much memory.
//! - A connection that sends its head slower than [`HEAD_DEADLINE`] is dropped (408), so one
//!   slow client holds the server that long at most.
//! - The `Host` header must name the loopback address the server listens on (`127.0.0.1`,
//!   `localhost` or `[::1]`, with the server's port or none): a page of another site that a
//!   DNS rebinding points at 127.0.0.1 sends its own host name and is refused (403).
//! - No answer repeats any part of the request (its path, its headers).

use std::io::{ErrorKind, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::time::{Duration, Instant};

/// The longest request line served (method, target and version; longer: 414).
pub const MAX_REQUEST_LINE_BYTES: usize = 2048;

/// The longest request head served: request line and headers with their line ends (longer:
/// 431).
pub const MAX_HEAD_BYTES: usize = 8192;

/// The longest a client may take to send its request head (then 408).
pub const HEAD_DEADLINE: Duration = Duration::from_secs(2);

/// The most bytes read after an answer to a refused request, so that closing the connection
/// does not reset it under the answer while the client is still sending (then closed anyway).
const DRAIN_BYTES: u64 = 1 << 20;

/// The host names the server answers to (with its port, or none).
const LOOPBACK_HOSTS: [&str; 3] = ["127.0.0.1", "localhost", "[::1]"];

/// A request the server serves: a `GET` (or `HEAD`) of a target on this host.
#[derive(Debug, PartialEq, Eq)]
pub struct Request {
    /// `HEAD`: the answer has no body.
    pub head_only: bool,
    /// The path, without the query.
    pub path: String,
    /// The query (after `?`), or empty.
    pub query: String,
}

/// An answer.
#[derive(Debug, PartialEq, Eq)]
pub struct Response {
    /// The status code.
    pub status: u16,
    /// The `Content-Type`.
    pub content_type: &'static str,
    /// The body.
    pub body: String,
}

impl Response {
    /// A plain-text answer of constant words (never words of the request).
    fn refusal(status: u16, words: &'static str) -> Response {
        Response {
            status,
            content_type: "text/plain; charset=utf-8",
            body: format!("{words}\n"),
        }
    }
}

/// Why a request is not served, as the answer that says so.
#[derive(Debug, PartialEq, Eq)]
pub enum Refused {
    /// The client closed the connection (or sent nothing) before a whole head: no answer.
    Gone,
    /// An answer refusing the request.
    Answer(Response),
}

fn refuse(status: u16, words: &'static str) -> Refused {
    Refused::Answer(Response::refusal(status, words))
}

/// The reason phrase of a status code.
fn reason(status: u16) -> &'static str {
    match status {
        200 => "OK",
        400 => "Bad Request",
        403 => "Forbidden",
        404 => "Not Found",
        405 => "Method Not Allowed",
        408 => "Request Timeout",
        414 => "URI Too Long",
        431 => "Request Header Fields Too Large",
        503 => "Service Unavailable",
        _ => "Error",
    }
}

/// Reads one request head from `input` and checks it for a server on `port`: never more than
/// [`MAX_HEAD_BYTES`] bytes of it, and never past `deadline`.
pub fn read_request<R: Read>(
    input: &mut R,
    port: u16,
    deadline: Instant,
) -> Result<Request, Refused> {
    let head = read_head(input, deadline)?;
    parse_head(&head, port)
}

/// The bytes of a request head up to its blank line (excluded), read in small pieces.
fn read_head<R: Read>(input: &mut R, deadline: Instant) -> Result<Vec<u8>, Refused> {
    let mut head: Vec<u8> = Vec::with_capacity(1024);
    let mut piece = [0u8; 512];
    // Each turn reads at least one byte or ends: at most MAX_HEAD_BYTES turns.
    loop {
        if let Some(end) = find_blank_line(&head) {
            head.truncate(end);
            return Ok(head);
        }
        let line_ends = head.iter().position(|&b| b == b'\n');
        if line_ends.map_or(head.len(), |n| n + 1) > MAX_REQUEST_LINE_BYTES {
            return Err(refuse(
                414,
                "request line too long: the live view's addresses are short",
            ));
        }
        if head.len() >= MAX_HEAD_BYTES {
            return Err(refuse(
                431,
                "request headers too large: the live view takes at most 8 KiB of them",
            ));
        }
        if Instant::now() >= deadline {
            return Err(refuse(408, "the request took too long to arrive"));
        }
        let room = (MAX_HEAD_BYTES - head.len()).min(piece.len());
        match input.read(&mut piece[..room]) {
            Ok(0) => return Err(Refused::Gone),
            Ok(n) => head.extend_from_slice(&piece[..n]),
            Err(e) if e.kind() == ErrorKind::Interrupted => {}
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {
                return Err(refuse(408, "the request took too long to arrive"));
            }
            Err(_) => return Err(Refused::Gone),
        }
    }
}

/// Where the head's blank line starts (`\r\n\r\n`, or `\n\n` from a lax client).
fn find_blank_line(bytes: &[u8]) -> Option<usize> {
    let crlf = bytes.windows(4).position(|w| w == b"\r\n\r\n");
    let lf = bytes.windows(2).position(|w| w == b"\n\n");
    match (crlf, lf) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    }
}

/// Checks a request head: its method, its target and its `Host`.
fn parse_head(head: &[u8], port: u16) -> Result<Request, Refused> {
    let text = std::str::from_utf8(head).map_err(|_| refuse(400, "the request is not text"))?;
    let mut lines = text.split('\n').map(|l| l.strip_suffix('\r').unwrap_or(l));
    let request_line = lines.next().unwrap_or_default();
    let mut parts = request_line.split(' ');
    let (method, target, version) = match (parts.next(), parts.next(), parts.next(), parts.next()) {
        (Some(m), Some(t), Some(v), None) if v.starts_with("HTTP/1.") => (m, t, v),
        _ => return Err(refuse(400, "malformed request line")),
    };
    let head_only = match method {
        "GET" => false,
        "HEAD" => true,
        _ => return Err(refuse(405, "the live view answers GET only")),
    };
    let mut hosts = Vec::new();
    for line in lines {
        let Some((name, value)) = line.split_once(':') else {
            return Err(refuse(400, "malformed header line"));
        };
        if name.eq_ignore_ascii_case("host") {
            hosts.push(value.trim());
        }
    }
    match hosts[..] {
        [host] if is_loopback_host(host, port) => {}
        [_] => {
            return Err(refuse(
                403,
                "this server answers only to its loopback address (127.0.0.1, localhost or \
                 [::1]); open the URL that `swarmfl run --live` printed",
            ))
        }
        [] if version == "HTTP/1.0" => {}
        _ => return Err(refuse(400, "the request needs exactly one Host header")),
    }
    if !target.starts_with('/') {
        return Err(refuse(400, "the request target must be a path"));
    }
    let (path, query) = target.split_once('?').unwrap_or((target, ""));
    Ok(Request {
        head_only,
        path: path.to_string(),
        query: query.to_string(),
    })
}

/// Whether `host` (a `Host` header's value) names this server: a loopback name with our port
/// or none.
fn is_loopback_host(host: &str, port: u16) -> bool {
    let (name, given) = match host.rsplit_once(':') {
        // "[::1]" alone has colons inside its brackets only.
        Some((name, p)) if !p.ends_with(']') => (name, Some(p)),
        _ => (host, None),
    };
    let port_ok = given.is_none_or(|p| p.parse::<u16>() == Ok(port));
    port_ok && LOOPBACK_HOSTS.iter().any(|&h| h.eq_ignore_ascii_case(name))
}

/// Writes `response` (its body too unless `head_only`) and closes the connection's write side.
fn send(stream: &mut TcpStream, response: &Response, head_only: bool) -> std::io::Result<()> {
    let head = format!(
        "HTTP/1.1 {} {}\r\nContent-Type: {}\r\nContent-Length: {}\r\nCache-Control: no-store\r\n\
         X-Content-Type-Options: nosniff\r\nConnection: close\r\n\r\n",
        response.status,
        reason(response.status),
        response.content_type,
        response.body.len()
    );
    stream.write_all(head.as_bytes())?;
    if !head_only {
        stream.write_all(response.body.as_bytes())?;
    }
    stream.flush()?;
    stream.shutdown(std::net::Shutdown::Write)
}

/// The listening socket of the live view.
pub struct Server {
    listener: TcpListener,
}

impl Server {
    /// Listens on `127.0.0.1:port` (`0`: any free port).
    pub fn bind(port: u16) -> std::io::Result<Server> {
        let listener = TcpListener::bind(("127.0.0.1", port))?;
        listener.set_nonblocking(true)?;
        Ok(Server { listener })
    }

    /// The port listened on.
    pub fn port(&self) -> std::io::Result<u16> {
        Ok(self.listener.local_addr()?.port())
    }

    /// Waits up to `wait` for a connection and answers its request with `answer`; returns
    /// whether a connection came. A connection's failure is no error of the server's.
    pub fn serve_one(
        &self,
        wait: Duration,
        answer: impl FnOnce(&Request) -> Response,
    ) -> std::io::Result<bool> {
        let until = Instant::now() + wait;
        // Each turn sleeps a slice of `wait` or takes a connection: at most wait / 20 ms turns.
        let mut stream = loop {
            match self.listener.accept() {
                Ok((stream, _)) => break stream,
                Err(e) if e.kind() == ErrorKind::WouldBlock => {
                    if Instant::now() >= until {
                        return Ok(false);
                    }
                    std::thread::sleep(Duration::from_millis(20).min(wait));
                }
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
        };
        let port = self.port()?;
        let _ = handle(&mut stream, port, answer);
        Ok(true)
    }
}

/// Reads one request from `stream`, answers it and closes the connection.
fn handle(
    stream: &mut TcpStream,
    port: u16,
    answer: impl FnOnce(&Request) -> Response,
) -> std::io::Result<()> {
    stream.set_nonblocking(false)?;
    stream.set_read_timeout(Some(HEAD_DEADLINE))?;
    stream.set_write_timeout(Some(Duration::from_secs(10)))?;
    let deadline = Instant::now() + HEAD_DEADLINE;
    match read_request(stream, port, deadline) {
        Ok(request) => send(stream, &answer(&request), request.head_only),
        Err(Refused::Gone) => Ok(()),
        Err(Refused::Answer(refusal)) => {
            send(stream, &refusal, false)?;
            // Read (and drop) a bounded rest of what the client still sends, so the close
            // does not reset the connection before the client has read the answer.
            stream.set_read_timeout(Some(Duration::from_millis(500)))?;
            let _ = std::io::copy(&mut stream.take(DRAIN_BYTES), &mut std::io::sink());
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An endless request: `prefix`, then `fill` for ever; counts the bytes handed out.
    struct Endless {
        prefix: Vec<u8>,
        fill: u8,
        given: usize,
    }

    impl Read for Endless {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            for (i, b) in buf.iter_mut().enumerate() {
                *b = self
                    .prefix
                    .get(self.given + i)
                    .copied()
                    .unwrap_or(self.fill);
            }
            self.given += buf.len();
            Ok(buf.len())
        }
    }

    fn far() -> Instant {
        Instant::now() + Duration::from_secs(3600)
    }

    fn status(r: Result<Request, Refused>) -> u16 {
        match r {
            Ok(_) => 200,
            Err(Refused::Answer(a)) => a.status,
            Err(Refused::Gone) => 0,
        }
    }

    fn check(head: &str, port: u16) -> u16 {
        status(read_request(&mut head.as_bytes(), port, far()))
    }

    #[test]
    fn an_endless_request_line_or_header_is_refused_after_a_bounded_read() {
        let mut line = Endless {
            prefix: b"GET /".to_vec(),
            fill: b'a',
            given: 0,
        };
        assert_eq!(status(read_request(&mut line, 8700, far())), 414);
        assert!(line.given <= MAX_REQUEST_LINE_BYTES + 512, "{}", line.given);
        let mut header = Endless {
            prefix: b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Big: ".to_vec(),
            fill: b'b',
            given: 0,
        };
        assert_eq!(status(read_request(&mut header, 8700, far())), 431);
        assert!(header.given <= MAX_HEAD_BYTES, "{}", header.given);
        // Many short headers are the same.
        let mut many = Endless {
            prefix: b"GET / HTTP/1.1\r\n".to_vec(),
            fill: b'\n',
            given: 0,
        };
        many.prefix.extend(b"X: y\r\n".repeat(4000));
        assert_eq!(status(read_request(&mut many, 8700, far())), 431);
        assert!(many.given <= MAX_HEAD_BYTES);
    }

    #[test]
    fn only_the_loopback_host_with_our_port_is_served() {
        for host in [
            "127.0.0.1:8700",
            "localhost:8700",
            "[::1]:8700",
            "127.0.0.1",
            "LOCALHOST",
            "[::1]",
        ] {
            let head = format!("GET /data.json?have=3 HTTP/1.1\r\nHost: {host}\r\n\r\n");
            assert_eq!(check(&head, 8700), 200, "{host}");
        }
        for host in [
            "evil.example",
            "evil.example:8700",
            "127.0.0.1:8701",
            "localhost.evil.example:8700",
            "127.0.0.2:8700",
            "[::2]:8700",
            "",
        ] {
            let head = format!("GET / HTTP/1.1\r\nHost: {host}\r\n\r\n");
            assert_eq!(check(&head, 8700), 403, "{host:?}");
        }
        // None, or two: refused; none from HTTP/1.0 (which had no Host): served.
        assert_eq!(check("GET / HTTP/1.1\r\n\r\n", 8700), 400);
        let two = "GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nHost: evil.example\r\n\r\n";
        assert_eq!(check(two, 8700), 400);
        assert_eq!(check("GET / HTTP/1.0\r\n\r\n", 8700), 200);
    }

    #[test]
    fn requests_are_parsed_and_other_methods_refused() {
        let head = "GET /data.json?have=3 HTTP/1.1\r\nhost: localhost:8700\r\nAccept: */*\r\n\r\n";
        assert_eq!(
            read_request(&mut head.as_bytes(), 8700, far()).unwrap(),
            Request {
                head_only: false,
                path: "/data.json".into(),
                query: "have=3".into(),
            }
        );
        let post = "POST / HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: 3\r\n\r\nabc";
        assert_eq!(check(post, 8700), 405);
        assert_eq!(check("GET /\r\n\r\n", 8700), 400);
        assert_eq!(
            check("GET http://evil/ HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n", 8700),
            400
        );
        // A head that ends before its blank line: the client went away.
        assert_eq!(check("GET / HTTP/1.1\r\nHost: 127.0.0.1\r\n", 8700), 0);
        // Past the deadline, an incomplete head is not waited for.
        let past = Instant::now() - Duration::from_secs(1);
        let r = read_request(&mut "GET / HTTP/1.1\r\n".as_bytes(), 8700, past);
        assert_eq!(status(r), 408);
    }
}
