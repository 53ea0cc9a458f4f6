//! `octowrap view`: serves the MRQ web viewer and one file on localhost.
//!
//! The server is a small HTTP/1.1 server on the standard library, written here rather than taken
//! from a crate: the crates that serve byte ranges (tower-http's `ServeDir`, actix-files, warp)
//! bring an async runtime and about a hundred crates for one local file, and the small blocking
//! servers (`tiny_http`) leave `Range` to the caller anyway. It answers `GET` and `HEAD` for the
//! embedded viewer files and for the MRQ file, the latter with single byte ranges (RFC 9110
//! §14: `bytes=a-b`, `bytes=a-`, `bytes=-n`; 206 with `Content-Range`, 416 past the end; a
//! malformed or multi-range header gets the whole file, as the RFC allows). It listens on
//! 127.0.0.1 only, reads request heads of at most 16 KiB with a timeout, and serves at most
//! [`MAX_CONNECTIONS`] connections at once, one thread each.

use std::fmt::Write as _;
use std::io::{BufRead, BufReader, Read, Seek, SeekFrom, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Duration;

use anyhow::Context;

/// Open the MRQ web viewer on a file: serve it on localhost and open the page in a browser.
///
/// The page (tools/viewer/mrq.html, embedded in this binary) fetches the file with HTTP range
/// requests, decodes it in WebAssembly in a Web Worker, and draws it with three.js: drag to orbit,
/// scroll to zoom. A chunked file (format version 5, as `reconstruct` writes) is shown
/// view-dependently: a coarse first frame, then, wherever the camera goes, the chunks the view
/// needs at one pixel of screen-space error, as one crack-free mesh; other files stream level by
/// level, coarsest first (add &mode=levels to the URL for that on any file, &px=N for another
/// error). Its panel shows the bytes fetched, level, chunks, faces and frame rate. The same page
/// works from any static host that answers range requests (nginx, object storage): open
/// mrq.html?src=URL.mrq there.
///
/// Prints the page's URL on standard output, then serves until stopped (Ctrl-C).
///
/// Exit codes: 2 the file is not a readable MRQ file, or the port cannot be opened.
///
/// Examples:
///   octowrap view dragon.mrq
///   octowrap view dragon.mrq --port 8080 --no-open
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// The MRQ file to show.
    pub file: PathBuf,
    /// Port on 127.0.0.1 (0: any free port).
    #[arg(long, default_value_t = 0)]
    pub port: u16,
    /// Print the URL without opening a browser.
    #[arg(long)]
    pub no_open: bool,
}

/// One embedded viewer file.
struct Asset {
    path: &'static str,
    mime: &'static str,
    bytes: &'static [u8],
}

include!(concat!(env!("OUT_DIR"), "/viewer_assets.rs"));

/// Most connections served at once; more wait in the listen queue.
const MAX_CONNECTIONS: usize = 64;
/// Longest request head (request line and headers).
const MAX_HEAD_BYTES: u64 = 16 << 10;
/// How long a connection may stay silent.
const IDLE_TIMEOUT: Duration = Duration::from_secs(15);

/// What the server serves.
struct Site {
    file: PathBuf,
    /// The file's URL path: `/data/` and its name, percent-encoded.
    file_path: String,
}

pub fn run(args: &Args) -> anyhow::Result<ExitCode> {
    let info = std::fs::File::open(&args.file)
        .map_err(anyhow::Error::from)
        .and_then(|f| Ok(octowrap_format::read_info(BufReader::new(f), &octowrap_format::Limits::default())?))
        .with_context(|| format!("{}: not a readable MRQ file", args.file.display()))?;
    if !MISSING.is_empty() {
        say!(
            "warning: this octowrap was built without the web viewer's files {}: run tools/viewer/build-wasm.sh \
             (after `npm ci` in tools/viewer), then build octowrap again",
            MISSING.join(", ")
        );
    }
    let listener = TcpListener::bind(("127.0.0.1", args.port))
        .with_context(|| format!("cannot listen on 127.0.0.1 port {}", args.port))?;
    let port = listener.local_addr()?.port();
    let name = args.file.file_name().map_or_else(|| "file.mrq".into(), |n| n.to_string_lossy().into_owned());
    let site = Arc::new(Site { file: args.file.clone(), file_path: format!("/data/{}", percent_encode(&name)) });
    let url = format!("http://127.0.0.1:{port}/mrq.html?src={}", site.file_path);
    crate::out::stdout(|w| writeln!(w, "{url}"))?;
    say!(
        "serving {} ({} levels, {} bytes) and the viewer; stop with Ctrl-C",
        args.file.display(),
        info.levels.len(),
        info.levels.last().map_or(info.preamble_size, |l| l.offset + l.stored_size)
    );
    if !args.no_open {
        open_browser(&url);
    }
    let active = Arc::new(AtomicUsize::new(0));
    for stream in listener.incoming() {
        let Ok(stream) = stream else { continue };
        if active.load(Ordering::Acquire) >= MAX_CONNECTIONS {
            continue; // dropped: the client retries or fails, the server stays within bounds
        }
        active.fetch_add(1, Ordering::AcqRel);
        let (site, active) = (Arc::clone(&site), Arc::clone(&active));
        std::thread::spawn(move || {
            // A failed connection concerns its client only.
            let _ = serve_connection(stream, &site);
            active.fetch_sub(1, Ordering::AcqRel);
        });
    }
    Ok(ExitCode::SUCCESS)
}

/// Opens `url` in the desktop's browser; says so when it cannot.
fn open_browser(url: &str) {
    let mut cmd = if cfg!(target_os = "macos") {
        std::process::Command::new("open")
    } else if cfg!(windows) {
        let mut c = std::process::Command::new("cmd");
        c.args(["/C", "start", ""]);
        c
    } else {
        std::process::Command::new("xdg-open")
    };
    let opened = cmd
        .arg(url)
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn();
    if opened.is_err() {
        say!("could not open a browser: open {url} by hand");
    }
}

/// A parsed request head.
struct Request {
    method: String,
    path: String,
    range: Option<String>,
    close: bool,
}

/// Serves requests on one connection until the client closes it, asks to, or stays silent.
fn serve_connection(stream: TcpStream, site: &Site) -> std::io::Result<()> {
    stream.set_read_timeout(Some(IDLE_TIMEOUT))?;
    stream.set_write_timeout(Some(IDLE_TIMEOUT))?;
    let mut reader = BufReader::new(stream.try_clone()?);
    let mut writer = stream;
    loop {
        let request = match read_head(&mut reader) {
            Ok(Some(r)) => r,
            Ok(None) => return Ok(()),
            Err(HeadError::Bad(why)) => {
                respond(&mut writer, "400 Bad Request", "text/plain", &[], why.as_bytes(), false)?;
                // A lingering close: the client's unread bytes would otherwise turn the close into
                // a reset that can destroy the response before it is read.
                writer.shutdown(std::net::Shutdown::Write)?;
                writer.set_read_timeout(Some(Duration::from_secs(1)))?;
                let _ = std::io::copy(&mut reader.take(1 << 20), &mut std::io::sink());
                return Ok(());
            }
            Err(HeadError::Io(e)) => return Err(e),
        };
        let keep = handle(&mut writer, site, &request)?;
        if !keep || request.close {
            return Ok(());
        }
    }
}

enum HeadError {
    Bad(String),
    Io(std::io::Error),
}

/// Reads one request head; `None` when the client closed the connection between requests.
fn read_head(reader: &mut impl BufRead) -> Result<Option<Request>, HeadError> {
    let mut limited = reader.take(MAX_HEAD_BYTES);
    let mut line = String::new();
    if limited.read_line(&mut line).map_err(HeadError::Io)? == 0 {
        return Ok(None);
    }
    let mut parts = line.split_ascii_whitespace();
    let (Some(method), Some(target), Some(version)) = (parts.next(), parts.next(), parts.next()) else {
        return Err(HeadError::Bad("malformed request line".into()));
    };
    let mut request = Request {
        method: method.to_owned(),
        path: target.split('?').next().unwrap_or("").to_owned(),
        range: None,
        close: version == "HTTP/1.0",
    };
    loop {
        line.clear();
        if limited.read_line(&mut line).map_err(HeadError::Io)? == 0 {
            return Err(HeadError::Bad("request head too long or cut off".into()));
        }
        let header = line.trim_end_matches(['\r', '\n']);
        if header.is_empty() {
            return Ok(Some(request));
        }
        let Some((name, value)) = header.split_once(':') else {
            return Err(HeadError::Bad("malformed header line".into()));
        };
        let value = value.trim();
        if name.eq_ignore_ascii_case("range") {
            request.range = Some(value.to_owned());
        } else if name.eq_ignore_ascii_case("connection") {
            request.close = value.eq_ignore_ascii_case("close");
        } else if (name.eq_ignore_ascii_case("content-length") && value != "0")
            || name.eq_ignore_ascii_case("transfer-encoding")
        {
            return Err(HeadError::Bad("request bodies are not accepted".into()));
        }
    }
}

/// Answers one request; `false` when the connection must close after it.
fn handle(w: &mut TcpStream, site: &Site, req: &Request) -> std::io::Result<bool> {
    let head = req.method == "HEAD";
    if req.method != "GET" && !head {
        respond(w, "405 Method Not Allowed", "text/plain", &[("Allow", "GET, HEAD")], b"GET or HEAD only\n", head)?;
        return Ok(true);
    }
    if req.path == "/" {
        let location = format!("/mrq.html?src={}", site.file_path);
        respond(w, "302 Found", "text/plain", &[("Location", &location)], b"", head)?;
        return Ok(true);
    }
    if req.path == site.file_path {
        return serve_file(w, &site.file, req.range.as_deref(), head);
    }
    if let Some(a) = ASSETS.iter().find(|a| a.path == req.path) {
        respond(w, "200 OK", a.mime, &[], a.bytes, head)?;
        return Ok(true);
    }
    let body = if Path::new(&req.path).extension().is_some_and(|e| e == "wasm")
        || req.path.starts_with("/pkg/")
        || req.path.starts_with("/node_modules/")
    {
        format!(
            "{} is not in this octowrap: it was built without the viewer's files ({}); run tools/viewer/build-wasm.sh, then build octowrap again\n",
            req.path,
            MISSING.join(", ")
        )
    } else {
        format!("{} not found\n", req.path)
    };
    respond(w, "404 Not Found", "text/plain; charset=utf-8", &[], body.as_bytes(), head)?;
    Ok(true)
}

/// Writes a whole response.
fn respond(
    w: &mut TcpStream,
    status: &str,
    mime: &str,
    extra: &[(&str, &str)],
    body: &[u8],
    head_only: bool,
) -> std::io::Result<()> {
    let mut out = format!(
        "HTTP/1.1 {status}\r\nContent-Type: {mime}\r\nContent-Length: {}\r\nCache-Control: no-store\r\n",
        body.len()
    );
    for (name, value) in extra {
        let _ = write!(out, "{name}: {value}\r\n");
    }
    out.push_str("\r\n");
    w.write_all(out.as_bytes())?;
    if !head_only {
        w.write_all(body)?;
    }
    w.flush()
}

/// A byte range `start..end` of a file of `len` bytes, from a `Range` header value.
#[derive(Debug, PartialEq, Eq)]
pub enum ByteRange {
    /// No usable range (absent, malformed or several ranges): the whole file.
    Whole,
    /// Bytes `start..end` (end exclusive).
    Part(u64, u64),
    /// The range starts at or beyond the end.
    Unsatisfiable,
}

/// Parses `bytes=a-b`, `bytes=a-` or `bytes=-n` against a file of `len` bytes (RFC 9110 §14.1.2).
pub fn parse_range(header: Option<&str>, len: u64) -> ByteRange {
    let Some(spec) = header.and_then(|h| h.trim().strip_prefix("bytes=")) else { return ByteRange::Whole };
    if spec.contains(',') {
        return ByteRange::Whole;
    }
    let Some((a, b)) = spec.trim().split_once('-') else { return ByteRange::Whole };
    let num =
        |s: &str| if s.is_empty() || !s.bytes().all(|c| c.is_ascii_digit()) { None } else { s.parse::<u64>().ok() };
    match (num(a), num(b)) {
        // The last n bytes.
        (None, Some(n)) if a.is_empty() => {
            if n == 0 || len == 0 {
                ByteRange::Unsatisfiable
            } else {
                ByteRange::Part(len - n.min(len), len)
            }
        }
        (Some(start), _) if start >= len => ByteRange::Unsatisfiable,
        (Some(start), None) if b.is_empty() => ByteRange::Part(start, len),
        (Some(start), Some(last)) if last >= start => ByteRange::Part(start, last.min(len - 1) + 1),
        _ => ByteRange::Whole,
    }
}

/// Serves the MRQ file, or the part a `Range` header asks for.
fn serve_file(w: &mut TcpStream, path: &Path, range: Option<&str>, head_only: bool) -> std::io::Result<bool> {
    let Ok(mut file) = std::fs::File::open(path) else {
        respond(w, "404 Not Found", "text/plain", &[], b"the file cannot be opened any more\n", head_only)?;
        return Ok(true);
    };
    let len = file.metadata()?.len();
    let (status, start, end) = match parse_range(range, len) {
        ByteRange::Whole => ("200 OK", 0, len),
        ByteRange::Part(s, e) => ("206 Partial Content", s, e),
        ByteRange::Unsatisfiable => {
            let total = format!("bytes */{len}");
            respond(w, "416 Range Not Satisfiable", "text/plain", &[("Content-Range", &total)], b"", head_only)?;
            return Ok(true);
        }
    };
    let mut out = format!(
        "HTTP/1.1 {status}\r\nContent-Type: application/octet-stream\r\nContent-Length: {}\r\n\
         Accept-Ranges: bytes\r\nCache-Control: no-store\r\n",
        end - start
    );
    if status.starts_with("206") {
        let _ = write!(out, "Content-Range: bytes {start}-{}/{len}\r\n", end - 1);
    }
    out.push_str("\r\n");
    w.write_all(out.as_bytes())?;
    if !head_only {
        file.seek(SeekFrom::Start(start))?;
        let sent = std::io::copy(&mut (&mut file).take(end - start), w)?;
        if sent < end - start {
            // The file shrank while being sent: the response cannot be completed.
            return Ok(false);
        }
    }
    w.flush()?;
    Ok(true)
}

/// `s` with every byte but unreserved ASCII percent-encoded (RFC 3986 §2.3).
fn percent_encode(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for b in s.bytes() {
        if b.is_ascii_alphanumeric() || b"-._~".contains(&b) {
            out.push(b as char);
        } else {
            let _ = write!(out, "%{b:02X}");
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::{ByteRange, parse_range, percent_encode};

    #[test]
    fn ranges_follow_rfc_9110() {
        let r = |h: &str| parse_range(Some(h), 100);
        assert_eq!(r("bytes=0-9"), ByteRange::Part(0, 10));
        assert_eq!(r("bytes=90-"), ByteRange::Part(90, 100));
        assert_eq!(r("bytes=90-1000"), ByteRange::Part(90, 100), "an end past the file is cut to it");
        assert_eq!(r("bytes=-10"), ByteRange::Part(90, 100));
        assert_eq!(r("bytes=-1000"), ByteRange::Part(0, 100));
        assert_eq!(r("bytes=100-"), ByteRange::Unsatisfiable);
        assert_eq!(r("bytes=-0"), ByteRange::Unsatisfiable);
        assert_eq!(parse_range(Some("bytes=-5"), 0), ByteRange::Unsatisfiable);
        for ignored in ["bytes=9-3", "bytes=0-1,5-6", "items=0-9", "bytes=a-9", "bytes=-", "bytes=+1-2", "bytes=0"] {
            assert_eq!(r(ignored), ByteRange::Whole, "{ignored}");
        }
        assert_eq!(parse_range(None, 100), ByteRange::Whole);
    }

    #[test]
    fn names_are_percent_encoded() {
        assert_eq!(percent_encode("dragon v2 (é).mrq"), "dragon%20v2%20%28%C3%A9%29.mrq");
    }
}
