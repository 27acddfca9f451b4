//! The progress bar with an injected clock and writer: ETA arithmetic, redraw throttle, clock
//! reads per step, quiet mode, short runs, and clearing the line.

use std::cell::Cell;
use std::time::Duration;

use master::progress::{Clock, Progress, REDRAW_INTERVAL, eta, write_duration};

/// A clock that only moves when told to, and counts how often it is read.
#[derive(Default)]
struct FakeClock {
    now: Cell<Duration>,
    reads: Cell<u64>,
}

impl FakeClock {
    fn advance(&self, d: Duration) {
        self.now.set(self.now.get() + d);
    }
}

impl Clock for FakeClock {
    fn now(&self) -> Duration {
        self.reads.set(self.reads.get() + 1);
        self.now.get()
    }
}

fn duration_text(d: Duration) -> String {
    let mut v = Vec::new();
    write_duration(&mut v, d).unwrap();
    String::from_utf8(v).unwrap()
}

/// Seconds of an `m:ss` or `h:mm:ss` text.
fn seconds(text: &str) -> u64 {
    text.split(':').fold(0, |acc, part| acc * 60 + part.parse::<u64>().unwrap())
}

/// The lines drawn so far (each redraw starts with `\r` and ends with the erase sequence).
fn drawn_lines(out: &[u8]) -> Vec<String> {
    String::from_utf8(out.to_vec())
        .unwrap()
        .split('\r')
        .filter(|s| !s.is_empty() && *s != "\x1b[K")
        .map(|s| s.trim_end_matches("\x1b[K").to_owned())
        .collect()
}

#[test]
fn eta_is_elapsed_times_remaining_over_done() {
    assert_eq!(eta(Duration::from_secs(10), 0.25), Some(Duration::from_secs(30)));
    assert_eq!(eta(Duration::from_secs(10), 0.5), Some(Duration::from_secs(10)));
    assert_eq!(eta(Duration::from_secs(10), 1.0), Some(Duration::ZERO));
    assert_eq!(eta(Duration::from_secs(10), 1.5), Some(Duration::ZERO));
    assert_eq!(eta(Duration::from_secs(10), 0.0), None);
    assert_eq!(eta(Duration::from_secs(10), f64::NAN), None);
    assert_eq!(eta(Duration::from_secs(10), -0.1), None);
}

#[test]
fn durations_read_as_minutes_and_hours() {
    assert_eq!(duration_text(Duration::from_millis(59_999)), "0:59");
    assert_eq!(duration_text(Duration::from_secs(75)), "1:15");
    assert_eq!(duration_text(Duration::from_secs(3725)), "1:02:05");
}

#[test]
fn redraws_at_most_ten_times_a_second_and_reads_the_clock_rarely() {
    // 100 000 steps of 0.1 ms each: 10 s of wall time.
    let clock = FakeClock::default();
    let steps = 100_000u64;
    let mut bar = Progress::with_parts(Vec::new(), &clock, steps, 1000.0, true);
    for k in 1..=steps {
        clock.advance(Duration::from_micros(100));
        bar.update(k, k as f64 * 0.01);
    }
    let draws = drawn_lines(bar.writer()).len();
    let wall = Duration::from_secs(10);
    let most = (wall.as_secs_f64() / REDRAW_INTERVAL.as_secs_f64()) as usize;
    assert!(draws <= most, "{draws} redraws in 10 s, at most {most} allowed");
    // The clock is read about every 25 ms, so a redraw is at most that late: ≥ 10 s / 125 ms.
    assert!(draws >= 80, "only {draws} redraws in 10 s");
    let reads = clock.reads.get();
    assert!(reads < 1_000, "clock read {reads} times for {steps} steps");
}

#[test]
fn the_line_shows_fraction_simulated_time_elapsed_and_remaining() {
    // Constant rate: step k is done at k × 10 ms, simulated time k × 0.01 s, 1000 steps.
    let clock = FakeClock::default();
    let mut bar = Progress::with_parts(Vec::new(), &clock, 1000, 10.0, true);
    for k in 1..=600u64 {
        clock.advance(Duration::from_millis(10));
        bar.update(k, k as f64 * 0.01);
    }
    let lines = drawn_lines(bar.writer());
    assert!(!lines.is_empty());
    for line in &lines {
        assert!(line.starts_with('[') && line.len() < 80, "line {line:?}");
        // "[====>   ]  38.2%  t 3.82/10.00 s  elapsed 0:03  left 0:06"
        let words: Vec<&str> = line.split(']').nth(1).unwrap().split_whitespace().collect();
        let percent: f64 = words[0].trim_end_matches('%').parse().unwrap();
        let t: f64 = words[2].split('/').next().unwrap().parse().unwrap();
        assert_eq!(words[2].split('/').nth(1), Some("10.00"));
        let step = (t / 0.01).round() as u64;
        assert!((percent - step as f64 / 10.0).abs() < 0.051, "{line:?}");
        let elapsed = Duration::from_millis(10 * step);
        let left = Duration::from_millis(10 * (1000 - step));
        assert_eq!(words[5], duration_text(elapsed), "{line:?}");
        // The estimate is computed in floating point, so it may fall just below a whole second.
        let shown_left = seconds(words[7]) as f64;
        assert!((shown_left - left.as_secs_f64()).abs() <= 1.0, "{line:?}: expected {left:?} left");
        // Bar length proportional to the fraction (24 characters).
        let filled = line.chars().filter(|&c| c == '=').count();
        assert_eq!(filled, (step as usize * 24) / 1000, "{line:?}");
    }
}

#[test]
fn quiet_bar_never_reads_the_clock_or_writes() {
    let clock = FakeClock::default();
    let mut bar = Progress::with_parts(Vec::new(), &clock, 1000, 10.0, false);
    let reads_at_start = clock.reads.get();
    for k in 1..=1000u64 {
        clock.advance(Duration::from_millis(10));
        bar.update(k, k as f64 * 0.01);
    }
    bar.finish();
    assert!(!bar.is_enabled());
    assert_eq!(clock.reads.get(), reads_at_start);
    assert!(bar.writer().is_empty());
}

#[test]
fn short_runs_draw_nothing() {
    let clock = FakeClock::default();
    let mut bar = Progress::with_parts(Vec::new(), &clock, 50, 0.5, true);
    for k in 1..=50u64 {
        clock.advance(Duration::from_millis(1));
        bar.update(k, k as f64 * 0.01);
    }
    bar.finish();
    assert!(bar.writer().is_empty(), "{:?}", String::from_utf8_lossy(bar.writer()));
}

#[test]
fn finish_clears_the_line_and_stops_drawing() {
    let clock = FakeClock::default();
    let mut bar = Progress::with_parts(Vec::new(), &clock, 100, 1.0, true);
    for k in 1..=50u64 {
        clock.advance(Duration::from_millis(20));
        bar.update(k, k as f64 * 0.01);
    }
    assert!(!bar.writer().is_empty());
    bar.finish();
    assert!(bar.writer().ends_with(b"\r\x1b[K"));
    let len = bar.writer().len();
    for k in 51..=100u64 {
        clock.advance(Duration::from_millis(20));
        bar.update(k, k as f64 * 0.01);
    }
    bar.finish();
    assert_eq!(bar.writer().len(), len);
}

#[test]
fn without_a_step_count_the_fraction_comes_from_simulated_time() {
    let clock = FakeClock::default();
    let mut bar = Progress::with_parts(Vec::new(), &clock, 0, 8.0, true);
    for k in 1..=200u64 {
        clock.advance(Duration::from_millis(10));
        bar.update(k, k as f64 * 0.01);
    }
    let last = drawn_lines(bar.writer()).pop().unwrap();
    let words: Vec<&str> = last.split(']').nth(1).unwrap().split_whitespace().collect();
    let percent: f64 = words[0].trim_end_matches('%').parse().unwrap();
    let t: f64 = words[2].split('/').next().unwrap().parse().unwrap();
    assert!((percent - 100.0 * t / 8.0).abs() < 0.051, "{last:?}");
}
