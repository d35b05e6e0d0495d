//! A small WebDriver harness for tests that need a real browser: Debian's headless Chromium,
//! driven by `chromedriver` through `fantoccini`.
//!
//! Each [`Browser`] starts its own `chromedriver` on a free loopback port, with a fresh Chromium
//! profile in a temporary directory, so tests can run in parallel. Dropping it (also while a test
//! panics) ends the session and kills `chromedriver`; [`Browser::close`] does the same
//! explicitly. All waiting is in real time (polling every 100 ms), never Chromium's virtual time,
//! which does not drive the media pipeline reliably.
//!
//! Skip policy: when `chromedriver` (`/usr/bin/chromedriver` or on `PATH`) or `chromium`
//! (`/usr/bin/chromium` or on `PATH`) is missing, [`Browser::start`] prints `skipped: ...` and
//! returns `None`, and the test returns early, like the ffprobe-based tests. With
//! `FACSLAB_REQUIRE_BROWSER=1` (CI sets it) a missing browser fails the test instead. Once both
//! programs are there, any failure to start them fails the test.
//!
//! The helpers panic with context on any WebDriver error, so a test reads as a plain script:
//!
//! ```ignore
//! #[tokio::test(flavor = "multi_thread")]
//! async fn page_says_hello() {
//!     let Some(browser) = Browser::start().await else { return };
//!     browser.goto("file:///tmp/page.html").await;
//!     browser.wait_for("document.title === 'hello'", TIMEOUT).await;
//!     browser.click("button#next").await;
//!     browser.close().await;
//! }
//! ```

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use fantoccini::elements::Element;
use fantoccini::{Client, ClientBuilder, Locator};
use hyper_util::client::legacy::connect::HttpConnector;
use serde_json::{Value, json};

/// A generous default for [`Browser::wait_for`] and [`Browser::wait_until`]: a loaded 2-core CI
/// machine can be slow, and a passing test never waits this long.
pub const TIMEOUT: Duration = Duration::from_secs(60);

/// Interval between two polls of a wait.
const POLL: Duration = Duration::from_millis(100);

/// Chromium's command line (besides `--user-data-dir`).
const CHROMIUM_ARGS: &[&str] = &[
    "--headless=new",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-dev-shm-usage",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--autoplay-policy=no-user-gesture-required",
    "--window-size=1280,900",
];

/// A headless Chromium session with its own `chromedriver`.
pub struct Browser {
    client: Client,
    /// The WebDriver session, to end it from `Drop` (`None` once closed).
    session: Option<String>,
    driver: Driver,
}

/// A running `chromedriver`, killed on drop.
struct Driver {
    child: Child,
    port: u16,
    /// Chromium's profile and `chromedriver`'s log.
    dir: tempfile::TempDir,
}

impl Browser {
    /// Starts `chromedriver` and opens a Chromium session, or returns `None` (after printing
    /// `skipped: ...`) when either program is missing and `FACSLAB_REQUIRE_BROWSER` is not `1`.
    pub async fn start() -> Option<Browser> {
        let driver = find_program("chromedriver", "/usr/bin/chromedriver");
        let chromium = find_program("chromium", "/usr/bin/chromium");
        let (Some(driver), Some(chromium)) = (&driver, &chromium) else {
            let missing: Vec<&str> = [("chromedriver", &driver), ("chromium", &chromium)]
                .into_iter()
                .filter_map(|(name, path)| path.is_none().then_some(name))
                .collect();
            let message = format!("{} not found (apt-get install chromium chromium-driver)", missing.join(" and "));
            assert!(std::env::var("FACSLAB_REQUIRE_BROWSER").as_deref() != Ok("1"), "FACSLAB_REQUIRE_BROWSER=1, but {message}");
            eprintln!("skipped: {message}");
            return None;
        };
        let dir = tempfile::Builder::new().prefix("facslab-browser").tempdir().expect("a temporary directory");
        let driver = start_driver(driver, dir).await;

        let profile = driver.dir.path().join("profile");
        let mut args: Vec<String> = CHROMIUM_ARGS.iter().map(|a| a.to_string()).collect();
        args.push(format!("--user-data-dir={}", profile.display()));
        let capabilities = json!({
            "browserName": "chrome",
            "goog:chromeOptions": { "binary": chromium, "args": args },
        });
        let Value::Object(capabilities) = capabilities else { unreachable!() };
        let mut builder = ClientBuilder::new(HttpConnector::new());
        builder.capabilities(capabilities);
        let url = format!("http://127.0.0.1:{}", driver.port);
        let client = match tokio::time::timeout(TIMEOUT, builder.connect(&url)).await {
            Ok(Ok(client)) => client,
            Ok(Err(e)) => panic!("no Chromium session: {e}\n{}", driver.log()),
            Err(_) => panic!("no Chromium session after {} s\n{}", TIMEOUT.as_secs(), driver.log()),
        };
        let session = Some(client.session_id().await.ok().flatten().expect("a WebDriver session id"));
        Some(Browser { client, session, driver })
    }

    /// The underlying `fantoccini` client, for anything the helpers do not cover.
    pub fn client(&self) -> &Client {
        &self.client
    }

    /// Opens `url` (`file://`, `http://`, ...) and waits for its `load` event.
    pub async fn goto(&self, url: &str) {
        self.client.goto(url).await.unwrap_or_else(|e| panic!("goto {url}: {e}"));
    }

    /// Runs `js` as the body of a function (so use `return` to get a value) and returns its
    /// result as JSON.
    pub async fn execute(&self, js: &str) -> Value {
        self.client.execute(js, Vec::new()).await.unwrap_or_else(|e| panic!("script failed: {e}\n{js}"))
    }

    /// Polls the JavaScript expression `js` every 100 ms until it is truthy and returns its
    /// value; panics after `timeout` (real time) with its last value.
    pub async fn wait_for(&self, js: &str, timeout: Duration) -> Value {
        let script = format!("return ({js});");
        self.wait_until(timeout, async |browser| match browser.client.execute(&script, Vec::new()).await {
            Ok(value) if truthy(&value) => Ok(value),
            Ok(value) => Err(format!("`{js}` is {value}")),
            Err(e) => Err(format!("`{js}` failed: {e}")),
        })
        .await
    }

    /// Calls `probe` every 100 ms until it returns `Ok`, and returns that value; panics after
    /// `timeout` (real time) with the last `Err` (make it say what was seen instead).
    pub async fn wait_until<T>(&self, timeout: Duration, mut probe: impl AsyncFnMut(&Browser) -> Result<T, String>) -> T {
        let start = Instant::now();
        loop {
            let last = match probe(self).await {
                Ok(value) => return value,
                Err(last) => last,
            };
            if start.elapsed() >= timeout {
                panic!("timed out after {:.1} s: {last}", start.elapsed().as_secs_f64());
            }
            tokio::time::sleep(POLL).await;
        }
    }

    /// The first element matching the CSS selector `css`, waiting up to [`TIMEOUT`] for it to
    /// appear.
    pub async fn find(&self, css: &str) -> Element {
        self.client
            .wait()
            .at_most(TIMEOUT)
            .every(POLL)
            .for_element(Locator::Css(css))
            .await
            .unwrap_or_else(|e| panic!("no element {css}: {e}"))
    }

    /// The visible text of the element `css` (see [`Browser::find`]).
    pub async fn text(&self, css: &str) -> String {
        self.find(css).await.text().await.unwrap_or_else(|e| panic!("text of {css}: {e}"))
    }

    /// Clicks the element `css` (see [`Browser::find`]).
    pub async fn click(&self, css: &str) {
        self.find(css).await.click().await.unwrap_or_else(|e| panic!("click {css}: {e}"));
    }

    /// Replaces the content of the input `css` (see [`Browser::find`]) by typing `text`.
    pub async fn fill(&self, css: &str, text: &str) {
        let element = self.find(css).await;
        element.clear().await.unwrap_or_else(|e| panic!("clear {css}: {e}"));
        element.send_keys(text).await.unwrap_or_else(|e| panic!("type into {css}: {e}"));
    }

    /// Chooses the file `path` in the file input `css`, as picking it in the file dialog would.
    pub async fn upload(&self, css: &str, path: &Path) {
        let element = self.find(css).await;
        element.send_keys(&path.to_string_lossy()).await.unwrap_or_else(|e| panic!("choose {} in {css}: {e}", path.display()));
    }

    /// Drags the element `css` (see [`Browser::find`]) with the left mouse button, from its
    /// centre by `dx`, `dy` CSS pixels, in a few steps as a hand would (real pointer events).
    pub async fn drag(&self, css: &str, dx: f64, dy: f64) {
        use fantoccini::actions::{InputSource, MOUSE_BUTTON_LEFT, MouseActions, PointerAction};
        let element = self.find(css).await;
        let step = Some(Duration::from_millis(40));
        let mut mouse = MouseActions::new("mouse".into())
            .then(PointerAction::MoveToElement { element, duration: None, x: 0.0, y: 0.0 })
            .then(PointerAction::Down { button: MOUSE_BUTTON_LEFT });
        for _ in 0..4 {
            mouse = mouse.then(PointerAction::MoveBy { duration: step, x: dx / 4.0, y: dy / 4.0 });
        }
        mouse = mouse.then(PointerAction::Up { button: MOUSE_BUTTON_LEFT });
        self.client.perform_actions(mouse).await.unwrap_or_else(|e| panic!("drag {css} by {dx},{dy}: {e}"));
    }

    /// Saves a PNG of the viewport to `path` (creating its directory).
    pub async fn screenshot(&self, path: impl AsRef<Path>) {
        let path = path.as_ref();
        let png = self.client.screenshot().await.unwrap_or_else(|e| panic!("screenshot: {e}"));
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent).unwrap_or_else(|e| panic!("{}: {e}", parent.display()));
        }
        std::fs::write(path, png).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    }

    /// Resizes the window so that the page's viewport is `width`×`height` CSS pixels (e.g.
    /// 390×844 for a phone-size screenshot): headless Chromium's window includes some browser
    /// chrome, so the window is grown by whatever the viewport lacks. A loaded machine can apply
    /// a resize late, so the viewport is read again until it stops changing.
    pub async fn set_window_size(&self, width: u32, height: u32) {
        let (mut outer_w, mut outer_h) = (width, height);
        let mut last = (0, 0);
        for _attempt in 0..6 {
            self.client.set_window_size(outer_w, outer_h).await.unwrap_or_else(|e| panic!("window size {outer_w}x{outer_h}: {e}"));
            let (w, h) = self.settled_viewport().await;
            if (w, h) == (width as i64, height as i64) {
                return;
            }
            last = (w, h);
            outer_w = (outer_w as i64 + width as i64 - w).max(1) as u32;
            outer_h = (outer_h as i64 + height as i64 - h).max(1) as u32;
        }
        panic!("could not make the viewport {width}x{height} (it is {}x{})", last.0, last.1);
    }

    /// The viewport's size once two reads 50 ms apart agree (or after a second).
    async fn settled_viewport(&self) -> (i64, i64) {
        let read = async || {
            let inner = self.execute("return [window.innerWidth, window.innerHeight];").await;
            (inner[0].as_i64().unwrap_or(0), inner[1].as_i64().unwrap_or(0))
        };
        let mut previous = read().await;
        for _ in 0..20 {
            tokio::time::sleep(Duration::from_millis(50)).await;
            let now = read().await;
            if now == previous {
                return now;
            }
            previous = now;
        }
        previous
    }

    /// Ends the session (Chromium quits) and stops `chromedriver`. Dropping the `Browser` does the
    /// same; this only makes it explicit and reports a failure.
    pub async fn close(mut self) {
        self.client.clone().close().await.unwrap_or_else(|e| panic!("closing the session: {e}"));
        self.session = None;
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        // Ends the session synchronously (the async client cannot be awaited here), so that
        // chromedriver quits Chromium rather than leaving it running once it is killed.
        if let Some(session) = self.session.take() {
            let _ = http_delete(self.driver.port, &format!("/session/{session}"));
        }
    }
}

impl Driver {
    fn log(&self) -> String {
        let log = std::fs::read_to_string(self.dir.path().join("chromedriver.log")).unwrap_or_default();
        format!("chromedriver log:\n{log}")
    }
}

impl Drop for Driver {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// `fallback` if it exists, else `name` on `PATH`.
fn find_program(name: &str, fallback: &str) -> Option<PathBuf> {
    let fallback = PathBuf::from(fallback);
    if fallback.is_file() {
        return Some(fallback);
    }
    std::env::split_paths(&std::env::var_os("PATH")?).map(|dir| dir.join(name)).find(|path| path.is_file())
}

/// Starts `chromedriver` on a free loopback port and waits until it answers; tries again on
/// another port if it exits (the port was taken between probing and binding).
async fn start_driver(program: &Path, dir: tempfile::TempDir) -> Driver {
    let log_path = dir.path().join("chromedriver.log");
    let mut last = String::new();
    for _attempt in 0..3 {
        let port = TcpListener::bind("127.0.0.1:0").and_then(|l| l.local_addr()).expect("a free loopback port").port();
        let log = std::fs::File::create(&log_path).expect("chromedriver's log file");
        let mut child = Command::new(program)
            .arg(format!("--port={port}"))
            .stdin(Stdio::null())
            .stdout(log.try_clone().expect("chromedriver's log file"))
            .stderr(log)
            .spawn()
            .unwrap_or_else(|e| panic!("{}: {e}", program.display()));
        let start = Instant::now();
        last = loop {
            if let Ok(Some(status)) = child.try_wait() {
                break format!("chromedriver exited ({status})");
            }
            if let Ok(response) = reqwest::get(format!("http://127.0.0.1:{port}/status")).await
                && response.status().is_success()
            {
                return Driver { child, port, dir };
            }
            if start.elapsed() > TIMEOUT {
                let _ = child.kill();
                let _ = child.wait();
                break format!("chromedriver did not answer on port {port} within {} s", TIMEOUT.as_secs());
            }
            tokio::time::sleep(POLL).await;
        };
    }
    panic!("{last}\nchromedriver log:\n{}", std::fs::read_to_string(&log_path).unwrap_or_default());
}

/// A blocking `DELETE` to chromedriver (for `Drop`); returns once the whole response is read
/// (chromedriver keeps the connection open after it).
fn http_delete(port: u16, path: &str) -> std::io::Result<()> {
    let address = SocketAddr::from(([127, 0, 0, 1], port));
    let mut stream = TcpStream::connect_timeout(&address, Duration::from_secs(5))?;
    stream.set_read_timeout(Some(Duration::from_secs(30)))?;
    write!(stream, "DELETE {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nContent-Length: 0\r\nConnection: close\r\n\r\n")?;
    let mut response = Vec::new();
    let mut chunk = [0; 4096];
    loop {
        let n = stream.read(&mut chunk)?;
        if n == 0 {
            return Ok(());
        }
        response.extend_from_slice(&chunk[..n]);
        let text = String::from_utf8_lossy(&response);
        if let Some(end) = text.find("\r\n\r\n") {
            let length = text[..end]
                .lines()
                .find_map(|line| line.to_ascii_lowercase().strip_prefix("content-length:").map(|v| v.trim().parse::<usize>().unwrap_or(0)))
                .unwrap_or(0);
            if response.len() >= end + 4 + length {
                return Ok(());
            }
        }
    }
}

/// JavaScript truthiness of a WebDriver result.
fn truthy(value: &Value) -> bool {
    match value {
        Value::Null => false,
        Value::Bool(b) => *b,
        Value::Number(n) => n.as_f64().is_some_and(|f| f != 0.0 && !f.is_nan()),
        Value::String(s) => !s.is_empty(),
        Value::Array(_) | Value::Object(_) => true,
    }
}

/// The harness itself: typing, clicking, scripts, waits, and a phone-size screenshot.
#[tokio::test(flavor = "multi_thread")]
async fn browser_harness_types_clicks_and_takes_phone_size_screenshots() {
    let Some(browser) = Browser::start().await else { return };
    let dir = tempfile::tempdir().unwrap();
    let page = r#"<!doctype html><html><head><title>harness</title></head><body>
<input id="name" value="old"><button id="go" onclick="setTimeout(() => {
  document.getElementById('out').textContent = 'hello ' + document.getElementById('name').value; }, 300)">go</button>
<div id="out"></div></body></html>"#;
    std::fs::write(dir.path().join("page.html"), page).unwrap();
    browser.goto(&format!("file://{}", dir.path().join("page.html").display())).await;
    assert_eq!(browser.execute("return document.title;").await, "harness");
    assert_eq!(browser.client().title().await.unwrap(), "harness");
    browser.fill("#name", "Ada").await;
    browser.click("#go").await;
    let text = browser.wait_for("document.getElementById('out').textContent", TIMEOUT).await;
    assert_eq!(text, "hello Ada");
    assert_eq!(browser.text("#out").await, "hello Ada");

    browser.set_window_size(390, 844).await;
    assert_eq!(browser.execute("return [window.innerWidth, window.innerHeight];").await, serde_json::json!([390, 844]));
    let png = dir.path().join("shots/phone.png");
    browser.screenshot(&png).await;
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&png).unwrap()));
    let info = decoder.read_info().unwrap();
    assert_eq!((info.info().width, info.info().height), (390, 844));
    browser.close().await;
}

