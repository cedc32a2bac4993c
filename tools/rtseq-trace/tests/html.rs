//! The HTML timeline of the demo's following-error run, written by the command-line tool
//! and opened in headless Chromium (Debian's `chromium`; `./x test` installs it): the
//! screenshot is not blank, and the page (after its script ran) has one row per sequence
//! and one marker per monitor firing of the run.
//!
//! The browser: `$RTSEQ_CHROMIUM`, else `chromium`, `chromium-browser` or `google-chrome`
//! on the PATH. Missing, the test fails (like the QEMU suites without QEMU).

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use rtseq_trace::model::{secs, EventKind};
use rtseq_trace::{html, tracefile};

fn chromium() -> PathBuf {
    if let Some(p) = std::env::var_os("RTSEQ_CHROMIUM") {
        return PathBuf::from(p);
    }
    for name in ["chromium", "chromium-browser", "google-chrome"] {
        let found = std::env::var_os("PATH")
            .map(|paths| std::env::split_paths(&paths).any(|d| d.join(name).is_file()))
            .unwrap_or(false);
        if found {
            return PathBuf::from(name);
        }
    }
    panic!(
        "headless Chromium not found: `./x test` installs it (apt-get install chromium), \
         or set RTSEQ_CHROMIUM"
    );
}

/// Runs headless Chromium with `args` on `page`; returns its stdout.
fn browse(profile: &Path, args: &[&str], page: &Path) -> String {
    let out = Command::new(chromium())
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--hide-scrollbars",
            "--no-first-run",
            "--allow-file-access-from-files",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .args(args)
        .arg(format!("file://{}", page.display()))
        .output()
        .expect("running chromium");
    assert!(
        out.status.success(),
        "chromium failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn render(dir: &Path) -> PathBuf {
    let page = dir.join("timeline.html");
    let st = Command::new(env!("CARGO_BIN_EXE_rtseq-trace"))
        .arg("render")
        .arg(common::manifest_dir().join("tests/fixtures/demo-following-error.log"))
        .arg("--tree")
        .arg(common::manifest_dir().join("demo.tree"))
        .arg("--html")
        .arg(&page)
        .status()
        .unwrap();
    assert!(st.success());
    page
}

#[test]
fn timeline_in_headless_chromium() {
    let dir = common::scratch("html");
    let page = render(&dir);
    let html = std::fs::read_to_string(&page).unwrap();
    for external in ["src=\"http", "href=\"http", "<link", "@import", "url("] {
        assert!(!html.contains(external), "self-contained: found {external}");
    }
    let run = common::fixture_run();
    // The run is complete: no warning.
    assert!(!html.contains(r#"class="lost-warning""#));

    // The page after its script ran.
    let dom = browse(&dir.join("profile-dom"), &["--dump-dom"], &page);
    let rows = dom.matches(r#"<g class="seq-row""#).count();
    assert_eq!(rows, run.sequences.len(), "one row per sequence");
    let fired = run
        .events
        .iter()
        .filter(|e| e.kind == EventKind::Monitor)
        .count();
    assert_eq!(fired, 4);
    assert_eq!(
        dom.matches(r#"class="marker monitor-fire""#).count(),
        fired,
        "one marker per monitor firing"
    );
    // The inline script drew the time axis (it ran, without errors).
    let axis = dom
        .split(r#"id="axis">"#)
        .nth(1)
        .and_then(|s| s.split("</g>").next())
        .unwrap_or("");
    assert!(axis.matches("<text").count() >= 5, "axis not drawn: {axis}");

    // The screenshot is not blank.
    let png_path = dir.join("timeline.png");
    let shot = format!("--screenshot={}", png_path.display());
    browse(
        &dir.join("profile-shot"),
        &[&shot, "--window-size=1400,800"],
        &page,
    );
    let decoder = png::Decoder::new(std::io::BufReader::new(
        std::fs::File::open(&png_path).unwrap(),
    ));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    let channels = info.color_type.samples();
    assert!(channels >= 3, "{:?}", info.color_type);
    let px = &buf[..info.buffer_size()];
    let (mut total, mut ink, mut green) = (0usize, 0usize, 0usize);
    for p in px.chunks(channels) {
        total += 1;
        let (r, g, b) = (p[0], p[1], p[2]);
        if r < 235 || g < 235 || b < 235 {
            ink += 1;
        }
        // The `Running` colour (#2e9b55).
        if r.abs_diff(0x2e) < 12 && g.abs_diff(0x9b) < 12 && b.abs_diff(0x55) < 12 {
            green += 1;
        }
    }
    assert_eq!((info.width, info.height), (1400, 800));
    assert!(
        ink * 10 > total,
        "screenshot nearly blank: {ink} of {total} pixels"
    );
    assert!(green * 50 > total, "few Running pixels: {green} of {total}");
}

#[test]
fn help_lists_the_commands() {
    let out = Command::new(env!("CARGO_BIN_EXE_rtseq-trace"))
        .arg("--help")
        .output()
        .unwrap();
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("render") && text.contains("live"), "{text}");
    let out = Command::new(env!("CARGO_BIN_EXE_rtseq-trace"))
        .args(["render", "--help"])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    for opt in ["--html", "--vcd", "--perfetto", "--trace", "--tree"] {
        assert!(text.contains(opt), "{text}");
    }
}

/// A trace file of one sequence `move`, started every ms: `runs` runs, each running 500 µs
/// and completing, except every 1000th, which is aborted (250 µs `Aborting`), and the last,
/// which has not ended.
fn many_runs(runs: u64) -> String {
    let mut text = String::from(
        r#"{"format":"rtseq-trace","version":1,"time_unit":"us","end":0,"sequences":[{"id":0,"name":"move","caller":null}],"monitors":[]}"#,
    );
    text.push('\n');
    let rec = |text: &mut String, t: u64, from: &str, to: &str, cause: &str| {
        text.push_str(&format!(
            r#"{{"t":{t},"seq":0,"from":"{from}","to":"{to}","cause":"{cause}"}}"#
        ));
        text.push('\n');
    };
    for k in 0..runs {
        let t = k * 1000;
        rec(&mut text, t, "Idle", "Running", "start");
        if k + 1 == runs {
            break;
        }
        if k % 1000 == 999 {
            rec(&mut text, t + 500, "Running", "Aborting", "abort");
            rec(&mut text, t + 750, "Aborting", "Aborted", "abort");
        } else {
            rec(&mut text, t + 500, "Running", "Terminated", "completed");
        }
    }
    text
}

/// The tooltip of a state span in the page (as `html::render` writes it, escaped).
fn tip(state: &str, from: u64, to: u64, cause: &str, outcome: &str) -> String {
    html::esc(&format!(
        "move: {state} from {} s to {} s ({} µs)\ncause: {cause}\nrun: started by start; outcome {outcome}",
        secs(from),
        secs(to),
        to - from
    ))
}

/// 100 000 runs of one sequence (a periodic sequence of a long simulation): one span per
/// state, and every span's tooltip names the run it belongs to. (How long it takes:
/// `cargo run --release --example html_scale`; rendering was quadratic in the runs.)
#[test]
fn timeline_of_100000_runs_of_one_sequence() {
    let n = 100_000u64;
    let run = tracefile::read(&many_runs(n)).unwrap();
    assert_eq!(run.transitions.len() as u64, 2 * n - 1 + (n - 1) / 1000);
    let page = html::render(&run, "100 000 runs");
    let aborted = (n - 1) / 1000;
    assert_eq!(page.matches(r#"class="span s-running""#).count() as u64, n);
    assert_eq!(
        page.matches(r#"class="span s-terminated""#).count() as u64,
        n - 1 - aborted
    );
    assert_eq!(
        page.matches(r#"class="span s-aborting""#).count() as u64,
        aborted
    );
    assert_eq!(
        page.matches(r#"class="span s-aborted""#).count() as u64,
        aborted
    );
    // Every span but the initial `Idle` has its run.
    let spans = 2 * n - 1 + aborted;
    assert_eq!(
        page.matches("\nrun: started by start; outcome ").count() as u64,
        spans
    );
    assert_eq!(
        page.matches("outcome aborted (abort)").count() as u64,
        3 * aborted
    );
    let last = (n - 1) * 1000;
    for want in [
        tip("Running", 0, 500, "start", "completed"),
        tip("Terminated", 500, 1000, "completed", "completed"),
        tip("Running", 998_000, 998_500, "start", "completed"),
        tip("Running", 999_000, 999_500, "start", "aborted (abort)"),
        tip("Aborting", 999_500, 999_750, "abort", "aborted (abort)"),
        tip("Aborted", 999_750, 1_000_000, "abort", "aborted (abort)"),
        tip("Running", 1_000_000, 1_000_500, "start", "completed"),
        tip("Running", 50_000_000, 50_000_500, "start", "completed"),
        tip("Terminated", last - 500, last, "completed", "completed"),
        tip("Running", last, last, "start", "still running"),
    ] {
        assert!(page.contains(&want), "no span with\n{want}");
    }
}

/// A trace whose header says records were lost: a banner at the top of the page says so,
/// and the command line warns on standard error.
#[test]
fn lost_records_banner() {
    let text = many_runs(3).replace(r#""end":0,"#, r#""end":0,"lost":5,"#);
    let run = tracefile::read(&text).unwrap();
    let page = html::render(&run, "lost");
    let banner = r#"<div class="lost-warning" role="alert"><b>Warning:</b> 5 records were lost: the trace is incomplete. Where in time they were is not known; runs and states may be missing anywhere.</div>"#;
    assert_eq!(page.matches(banner).count(), 1, "{}", &page[..2000]);
    // Above the chart.
    assert!(page.find(banner) < page.find(r#"<svg id="chart""#));
    assert!(page.contains(".lost-warning {"));

    let dir = common::scratch("lost");
    let input = dir.join("lost.jsonl");
    std::fs::write(&input, &text).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_rtseq-trace"))
        .arg("render")
        .arg(&input)
        .arg("--html")
        .arg(dir.join("lost.html"))
        .output()
        .unwrap();
    assert!(out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("rtseq-trace: warning: 5 records were lost: the trace is incomplete\n"),
        "{stderr}"
    );
    let written = std::fs::read_to_string(dir.join("lost.html")).unwrap();
    assert!(written.contains(banner));

    // None lost: no banner, no warning.
    let page = html::render(&tracefile::read(&many_runs(3)).unwrap(), "complete");
    assert!(!page.contains(r#"class="lost-warning""#));
    std::fs::write(&input, many_runs(3)).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_rtseq-trace"))
        .arg("render")
        .arg(&input)
        .arg("--html")
        .arg(dir.join("complete.html"))
        .output()
        .unwrap();
    assert!(out.status.success());
    assert!(!String::from_utf8_lossy(&out.stderr).contains("warning"));
}
