//! Progress of a long command on stderr: an `indicatif` bar on a terminal; otherwise (stderr a
//! pipe or a log file, where the bar draws nothing) a plain line at least every
//! [`PLAIN_INTERVAL`] while work runs, and one at the end: items done, rate, ETA.

use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// The longest time between two plain progress lines.
pub const PLAIN_INTERVAL: Duration = Duration::from_secs(3);

/// A progress report of `total` items (`what`: "frames", "images").
pub struct Progress {
    bar: Option<indicatif::ProgressBar>,
    plain: Arc<Plain>,
    ticker: Option<std::thread::JoinHandle<()>>,
}

struct Plain {
    label: &'static str,
    what: &'static str,
    total: u64,
    done: AtomicU64,
    stop: AtomicBool,
    start: Instant,
    /// Serialises stderr lines (the ticker's and the callers').
    lines: Mutex<()>,
}

impl Plain {
    fn line(&self) -> String {
        let done = self.done.load(Ordering::Relaxed);
        let secs = self.start.elapsed().as_secs_f64();
        let rate = done as f64 / secs.max(1e-9);
        let eta = if done == 0 { "?".to_string() } else { format!("{:.0} s", (self.total - done) as f64 / rate) };
        format!("{}: {done}/{} {} in {secs:.1} s, {rate:.2}/s, ETA {eta}", self.label, self.total, self.what)
    }
}

impl Progress {
    /// Starts the report of `total` items for the command `label`.
    pub fn new(label: &'static str, total: u64, what: &'static str) -> anyhow::Result<Self> {
        let plain = Arc::new(Plain {
            label,
            what,
            total,
            done: AtomicU64::new(0),
            stop: AtomicBool::new(false),
            start: Instant::now(),
            lines: Mutex::new(()),
        });
        if std::io::stderr().is_terminal() {
            let bar = indicatif::ProgressBar::new(total);
            bar.set_style(indicatif::ProgressStyle::with_template(&format!(
                "{{bar:40}} {{pos}}/{{len}} {what} {{per_sec}} eta {{eta}} {{msg}}"
            ))?);
            return Ok(Self { bar: Some(bar), plain, ticker: None });
        }
        let p = Arc::clone(&plain);
        let ticker = std::thread::spawn(move || {
            let mut last = Instant::now();
            while !p.stop.load(Ordering::Relaxed) {
                std::thread::sleep(Duration::from_millis(100));
                if last.elapsed() >= PLAIN_INTERVAL {
                    let _guard = p.lines.lock();
                    eprintln!("{}", p.line());
                    last = Instant::now();
                }
            }
        });
        Ok(Self { bar: None, plain, ticker: Some(ticker) })
    }

    /// One item done.
    pub fn inc(&self) {
        self.plain.done.fetch_add(1, Ordering::Relaxed);
        if let Some(bar) = &self.bar {
            bar.inc(1);
        }
    }

    /// A message line (above the bar on a terminal).
    pub fn println(&self, line: String) {
        match &self.bar {
            Some(bar) => bar.println(line),
            None => {
                let _guard = self.plain.lines.lock();
                eprintln!("{line}");
            }
        }
    }

    /// Ends the report: clears the bar, or prints the last plain line.
    pub fn finish(mut self) {
        self.stop();
        if self.bar.is_none() {
            eprintln!("{}", self.plain.line());
        }
    }

    fn stop(&mut self) {
        self.plain.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.ticker.take() {
            let _ = t.join();
        }
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}

impl Drop for Progress {
    /// An early return (an error) stops the ticker too.
    fn drop(&mut self) {
        self.stop();
    }
}
