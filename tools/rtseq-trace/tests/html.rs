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
    browse_at(profile, args, page, "")
}

/// [`browse`] at `page` with `hash` appended to its URL (`#t=29,40`).
fn browse_at(profile: &Path, args: &[&str], page: &Path, hash: &str) -> String {
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
        .arg(format!("file://{}{hash}", page.display()))
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
    // A run starts from the state the previous one ended in, as the sequencer records it.
    let mut ended = "Idle";
    for k in 0..runs {
        let t = k * 1000;
        rec(&mut text, t, ended, "Running", "start");
        if k + 1 == runs {
            break;
        }
        if k % 1000 == 999 {
            rec(&mut text, t + 500, "Running", "Aborting", "abort");
            rec(&mut text, t + 750, "Aborting", "Aborted", "abort");
            ended = "Aborted";
        } else {
            rec(&mut text, t + 500, "Running", "Terminated", "completed");
            ended = "Terminated";
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

/// The value of attribute `name` in the tag `tag` (`<rect ...>`), if it has it.
fn attr<'a>(tag: &'a str, name: &str) -> Option<&'a str> {
    let key = format!(" {name}=\"");
    let from = tag.find(&key)? + key.len();
    tag[from..].split('"').next()
}

/// The opening tags in `dom` that contain `needle`.
fn tags_with<'a>(dom: &'a str, needle: &str) -> Vec<&'a str> {
    dom.split('<')
        .filter(|t| t.contains(needle))
        .map(|t| t.split('>').next().unwrap_or(""))
        .collect()
}

/// Where the script drew the element whose tag contains `needle`: `x` and `width` of a
/// span, `x1` of a marker; `None` when it is hidden (outside the window).
fn drawn(dom: &str, needle: &str) -> Option<(String, String)> {
    let tags = tags_with(dom, needle);
    assert_eq!(tags.len(), 1, "one element with {needle}: {tags:?}");
    let tag = tags[0];
    if attr(tag, "display") == Some("none") {
        return None;
    }
    let (a, b) = if tag.starts_with("line") {
        ("x1", "x2")
    } else {
        ("x", "width")
    };
    Some((attr(tag, a)?.to_string(), attr(tag, b)?.to_string()))
}

fn at(x: &str, w: &str) -> Option<(String, String)> {
    Some((x.to_string(), w.to_string()))
}

/// Spans and markers late in a long run, or in a run whose time starts at 2^32 µs, sit
/// where their times say, at the whole-run view and zoomed to 10 µs. (The data were in an
/// SVG whose user units were µs; Blink clamps coordinates near 2^25, so everything after
/// 33.5 s was drawn at 33.5 s.)
#[test]
fn late_times_are_drawn_where_they_are() {
    let dir = common::scratch("late");
    let head = |end: u64, names: &[&str]| {
        let seqs: Vec<String> = names
            .iter()
            .enumerate()
            .map(|(i, n)| format!(r#"{{"id":{i},"name":"{n}","caller":null}}"#))
            .collect();
        format!(
            r#"{{"format":"rtseq-trace","version":1,"time_unit":"us","end":{end},"sequences":[{}],"monitors":[{{"id":0,"name":"jam","owner":1}}]}}"#,
            seqs.join(",")
        )
    };
    let run = |seq: usize, from: u64, to: u64| {
        format!(
            "{{\"t\":{from},\"seq\":{seq},\"from\":\"Idle\",\"to\":\"Running\",\"cause\":\"start\"}}\n{{\"t\":{to},\"seq\":{seq},\"from\":\"Running\",\"to\":\"Terminated\",\"cause\":\"completed\"}}\n"
        )
    };
    // 100 s: A 34–36 s, B 37–39 s, C the 5 µs from 99.999990 s; a monitor firing and its
    // exception sequence not run at 38 s.
    let long = format!(
        "{}\n{}{}{}{}\n{}\n",
        head(100_000_000, &["A", "B", "C"]),
        run(0, 34_000_000, 36_000_000),
        run(1, 37_000_000, 39_000_000),
        run(2, 99_999_990, 99_999_995),
        r#"{"t":38000000,"event":"monitor","owner":1,"behaviour":"AbortOwner","monitor":0,"text":"jam fired"}"#,
        r#"{"t":38000000,"event":"exception_not_run","sequence":2,"owner":1,"name":"C","text":"C not run"}"#,
    );
    // A run started at 2^32 µs (4294.967296 s): W runs 10 µs from 2^32 + 5.
    let late = format!(
        "{}\n{}",
        head((1 << 32) + 100, &["W"]),
        run(0, (1 << 32) + 5, (1 << 32) + 15)
    );
    let mut pages = Vec::new();
    for (name, text) in [("long", &long), ("late", &late)] {
        let input = dir.join(format!("{name}.jsonl"));
        std::fs::write(&input, text).unwrap();
        let page = dir.join(format!("{name}.html"));
        let st = Command::new(env!("CARGO_BIN_EXE_rtseq-trace"))
            .arg("render")
            .arg(&input)
            .arg("--html")
            .arg(&page)
            .status()
            .unwrap();
        assert!(st.success());
        pages.push(page);
    }
    let dom = |page: &Path, hash: &str| {
        let profile = dir.join(format!("profile{}", hash.len()));
        browse_at(&profile, &["--dump-dom"], page, hash)
    };
    let a = r#"class="span s-running" data-t0="34000000""#;
    let b = r#"class="span s-running" data-t0="37000000""#;
    let b_after = r#"class="span s-terminated" data-t0="39000000""#;
    let c = r#"class="span s-running" data-t0="99999990""#;
    let fired = r#"class="marker monitor-fire""#;
    let not_run = r#"class="marker exception""#;

    // The whole run, 100 s on 1180 px.
    let whole = dom(&pages[0], "");
    assert_eq!(drawn(&whole, a), at("401.2", "23.6"));
    assert_eq!(drawn(&whole, b), at("436.6", "23.6"));
    // 5 µs: at least 2 px wide.
    assert_eq!(drawn(&whole, c), at("1180", "2"));
    // The markers of one µs side by side, 3 px apart.
    assert_eq!(drawn(&whole, fired), at("448.4", "448.4"));
    assert_eq!(drawn(&whole, not_run), at("451.4", "451.4"));

    // 29 s to 40 s.
    let zoomed = dom(&pages[0], "#t=29,40");
    assert_eq!(drawn(&zoomed, a), at("536.36", "214.55"));
    assert_eq!(drawn(&zoomed, b), at("858.18", "214.55"));
    assert_eq!(drawn(&zoomed, fired), at("965.45", "965.45"));
    assert_eq!(drawn(&zoomed, not_run), at("968.45", "968.45"));
    assert_eq!(drawn(&zoomed, c), None);

    // The last 20 µs: C in the middle; B's `Terminated`, which began long before, cut 4 px
    // beyond the left edge, to the end of the run.
    let end = dom(&pages[0], "#t=99.99998,100");
    assert_eq!(drawn(&end, c), at("590", "295"));
    assert_eq!(drawn(&end, b_after), at("-4", "1184"));
    assert_eq!(drawn(&end, a), None);

    // The buttons and a drag still move the window: zoom in on 29 s to 40 s is 31.75 s to
    // 37.25 s; dragged 118 px (1.1 s) to the left, then zoomed out, 24.6 s to 46.6 s.
    let page = std::fs::read_to_string(&pages[0]).unwrap();
    let script = |s: &str| page.replace("</body>", &format!("<script>{s}</script></body>"));
    let zoom_in = dir.join("zoom-in.html");
    std::fs::write(&zoom_in, script("document.getElementById('zin').click();")).unwrap();
    let zoomed = dom(&zoom_in, "#t=29,40");
    assert_eq!(drawn(&zoomed, a), at("482.73", "429.09"));
    assert_eq!(drawn(&zoomed, b), at("1126.36", "57.64"));
    let dragged = dir.join("dragged.html");
    std::fs::write(
        &dragged,
        script(
            "var p = document.getElementById('plot');\
             p.dispatchEvent(new MouseEvent('mousedown', { clientX: 700, bubbles: true }));\
             window.dispatchEvent(new MouseEvent('mousemove', { clientX: 582 }));\
             window.dispatchEvent(new MouseEvent('mouseup'));\
             document.getElementById('zout').click();",
        ),
    )
    .unwrap();
    let moved = dom(&dragged, "#t=29,40");
    let axis: Vec<&str> = tags_with(&moved, r#"y="17">"#)
        .iter()
        .filter_map(|t| attr(t, "x"))
        .collect();
    assert_eq!(axis.first(), Some(&"265.09"), "the axis's first tick, 26 s");
    assert_eq!(drawn(&moved, a), at("504.18", "107.27"));

    // 10 µs from 2^32 µs.
    let w = r#"class="span s-running" data-t0="4294967301""#;
    let zoomed = dom(&pages[1], "#t=4294.967296,4294.967306");
    assert_eq!(drawn(&zoomed, w), at("590", "594"));
    let whole = dom(&pages[1], "");
    assert_eq!(drawn(&whole, w), at("1180", "2"));
}

/// A run that starts in the µs the previous one ended: each span's tooltip names its own
/// run (the `Running` after the restart named the aborted run).
#[test]
fn a_run_started_when_the_last_ended_is_named() {
    let text = r#"{"format":"rtseq-trace","version":1,"time_unit":"us","end":40,"sequences":[{"id":0,"name":"move","caller":null}],"monitors":[]}
{"t":0,"seq":0,"from":"Idle","to":"Running","cause":"start"}
{"t":10,"seq":0,"from":"Running","to":"Aborting","cause":"abort"}
{"t":20,"seq":0,"from":"Aborting","to":"Aborted","cause":"abort"}
{"t":20,"seq":0,"from":"Aborted","to":"Running","cause":"start"}
{"t":30,"seq":0,"from":"Running","to":"Terminated","cause":"completed"}
"#;
    let page = html::render(&tracefile::read(text).unwrap(), "same µs");
    for want in [
        tip("Running", 0, 10, "start", "aborted (abort)"),
        tip("Aborting", 10, 20, "abort", "aborted (abort)"),
        tip("Aborted", 20, 20, "abort", "aborted (abort)"),
        tip("Running", 20, 30, "start", "completed"),
        tip("Terminated", 30, 40, "completed", "completed"),
    ] {
        assert_eq!(page.matches(&want).count(), 1, "no span with\n{want}");
    }
}

/// A signal with a failed sample (`NaN`) between good ones: after the page's script ran,
/// the line is drawn in two pieces with numbers only, and the failed sample is a visible
/// mark placed on the time axis.
#[test]
fn a_failed_sample_breaks_the_line_in_chromium() {
    let dir = common::scratch("html-nan");
    let log = "0.000005 INFO  seq       main  Idle -> Running  (start)\n\
               0.001000 INFO  axis      x 1.0 mm  | x\n\
               0.002000 INFO  axis      x 2.0 mm  | x\n\
               0.003000 INFO  axis      x NaN mm  | x\n\
               0.004000 INFO  axis      x 3.0 mm  | x\n\
               0.005000 INFO  axis      x 2.5 mm  | x\n\
               0.006000 INFO  seq       main  Running -> Terminated  (completed)\n";
    let run = rtseq_trace::read_run(log, Default::default()).unwrap();
    let page = dir.join("nan.html");
    std::fs::write(&page, html::render(&run, "nan")).unwrap();
    let dom = browse(&dir.join("profile-nan"), &["--dump-dom"], &page);
    let lines: Vec<&str> = dom
        .split(r#"<polyline class="signal"#)
        .skip(1)
        .map(|l| {
            l.split(r#"points=""#)
                .nth(1)
                .and_then(|p| p.split('"').next())
                .unwrap_or("")
        })
        .collect();
    assert_eq!(lines.len(), 2, "{dom}");
    for points in &lines {
        assert_eq!(points.split(' ').count(), 2, "{points}");
        assert!(!points.contains("NaN"), "{points}");
    }
    let fault = dom
        .split(r#"class="sample fault""#)
        .nth(1)
        .expect("the failed sample's mark");
    let cx = fault
        .split(r#"cx=""#)
        .nth(1)
        .and_then(|c| c.split('"').next());
    assert!(
        cx.is_some_and(|c| c.parse::<f64>().is_ok_and(|x| x > 0.0)),
        "{fault}"
    );
}
