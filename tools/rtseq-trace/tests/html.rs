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

use rtseq_trace::model::EventKind;

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
