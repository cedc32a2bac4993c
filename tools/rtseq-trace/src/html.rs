//! A self-contained HTML timeline: one SVG, a little CSS and a little inline script, no
//! network.
//!
//! Layout, top to bottom on one time axis: one row per sequence (class `seq-row`, in tree
//! order, indented by caller) coloured by running state (class `span s-<state>`); the
//! safety level as a band (class `level-band`); the signals (position, velocity, current),
//! one plot each (class `signal`). Markers are vertical lines across the rows: a monitor
//! firing (class `marker monitor-fire`), a request (`marker request`), a fault
//! (`marker fault`), a tripped input (`marker input`). Every span and marker has an SVG
//! `<title>` with its details (hover); a span shorter than 2 pixels is drawn 2 pixels wide
//! (its title has the exact times). Markers of the same µs are drawn side by side, 3 pixels
//! apart, so that none hides another (a monitor firing and its exception sequence not run).
//!
//! Zoom: mouse wheel, drag to pan, the buttons; `page.html#t=2.4,2.8` opens on the window
//! from 2.4 s to 2.8 s (read to the µs). The inner `<svg id="plot">` is in pixels: every
//! span and level band carries its times in µs (`data-t0`, `data-t1`), every marker and
//! sample its time (`data-t`), every signal its samples (`data-pts`), and the script places
//! them relative to the visible window at each redraw, hiding what lies outside it and
//! cutting what reaches beyond it 4 pixels past the edge. So no coordinate in the DOM grows
//! beyond the plot's width, whatever the run's length and time origin: browsers clamp SVG
//! coordinates (Blink near 2^25), which drew everything after 33.5 s at 33.5 s when the
//! coordinates were µs. Times are exact to 2^53 µs (JavaScript numbers).
//!
//! The records decide the states ([`Run::state_spans_in`]): before a sequence's first record
//! it is drawn in that record's `from` state (its tooltip's cause: `unknown: the state before
//! the sequence's first record`), and a span after which the next record starts from another
//! state is drawn faded with a dashed red outline (class `gap`), its tooltip saying
//! `RECORDS LOST`.
//!
//! A run with lost records ([`Run::lost`]) gets a banner above the chart (class
//! `lost-warning`): `N records were lost: the trace is incomplete`.
//!
//! Linear in the size of the run: the transitions are grouped by sequence once, and the
//! run of each state span (for its tooltip: the run that holds the transition into the
//! span, even when it started in the µs the previous run ended) is found by walking the
//! sequence's runs and spans together, both in time order. The run must be in time order ([`Run::finish`];
//! both readers do it).

use std::fmt::Write as _;
use std::io::Write;

use crate::model::{secs, EventKind, Run, State};

const LABEL_W: f64 = 190.0;
const PLOT_W: f64 = 1180.0;
const ROW_H: f64 = 18.0;
const ROW_GAP: f64 = 3.0;
const TOP: f64 = 24.0;
const SIGNAL_H: f64 = 70.0;
const SIGNAL_GAP: f64 = 16.0;

/// Escapes text for HTML and XML.
pub fn esc(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            '\'' => o.push_str("&#39;"),
            c => o.push(c),
        }
    }
    o
}

/// The colours of the safety levels, in order of first appearance.
const LEVEL_COLOURS: [&str; 6] = [
    "#9e9e9e", "#f2c14e", "#5fb0e8", "#e0533d", "#8bc34a", "#b084cc",
];

fn state_class(s: State) -> String {
    format!("s-{}", s.name().to_lowercase())
}

/// Writes the timeline of `run`, titled `title`.
pub fn write(run: &Run, title: &str, out: &mut impl Write) -> std::io::Result<()> {
    out.write_all(render(run, title).as_bytes())
}

/// The timeline of `run` as one HTML document.
pub fn render(run: &Run, title: &str) -> String {
    let end = run.end_us.max(1);
    let order = run.tree_order();
    let by_seq = run.by_sequence();
    let rows = order.len() as f64;
    let level_y = TOP + rows * (ROW_H + ROW_GAP) + 6.0;
    let rows_bottom = level_y + ROW_H;
    let sig_top = rows_bottom + 26.0;
    let height = sig_top + run.signals.len() as f64 * (SIGNAL_H + SIGNAL_GAP) + 10.0;
    let width = LABEL_W + PLOT_W + 20.0;
    let mut levels: Vec<&str> = Vec::new();
    for l in &run.levels {
        if !levels.contains(&l.level.as_str()) {
            levels.push(&l.level);
        }
    }
    let level_colour = |name: &str| {
        let i = levels.iter().position(|l| *l == name).unwrap_or(0);
        LEVEL_COLOURS[i % LEVEL_COLOURS.len()]
    };

    let mut labels = String::new();
    let mut data = String::new();
    // Whether some span ends where records were lost (for the legend).
    let mut gaps = false;
    // Rows.
    for (row, (i, depth)) in order.iter().enumerate() {
        let Some(s) = run.sequences.get(*i) else {
            continue;
        };
        let y = TOP + row as f64 * (ROW_H + ROW_GAP);
        let _ = write!(
            labels,
            r#"<text class="label" x="{:.1}" y="{:.1}">{}</text>"#,
            8.0 + *depth as f64 * 12.0,
            y + ROW_H - 5.0,
            esc(&s.name)
        );
        let _ = write!(
            data,
            r#"<g class="seq-row" data-seq="{}"><rect class="row-bg" x="0" y="{y:.1}" width="{PLOT_W}" height="{ROW_H}"/>"#,
            esc(&s.name)
        );
        let trs = by_seq.get(*i).map_or(&[][..], Vec::as_slice);
        let runs = run.run_spans_in(trs);
        // Spans and runs are both in time order: the run of a span is the one holding the
        // transition into it (a run may start in the µs the previous one ended), found by
        // one index that only moves forward. The state before the first record belongs to
        // the first run if that run was under way.
        let mut r = 0;
        // Short states (a restart, an abort) and gaps are drawn last, on top.
        let mut on_top = String::new();
        let first = trs.first().copied();
        for sp in run.state_spans_in(trs) {
            if sp.state == State::Idle && sp.gap.is_none() {
                continue;
            }
            let k = sp
                .transition
                .or(first.filter(|_| sp.state.is_active()))
                .unwrap_or(usize::MAX);
            while runs
                .get(r)
                .is_some_and(|x| x.transitions.last().is_some_and(|&l| l < k))
            {
                r += 1;
            }
            let outcome = runs
                .get(r)
                .filter(|x| x.transitions.first().is_some_and(|&f| f <= k))
                .map(|x| format!("\nrun: started by {}; outcome {}", x.start_cause, x.outcome))
                .unwrap_or_default();
            let cause = match &sp.cause {
                Some(c) => c.clone(),
                None if sp.state == State::Idle => String::from("-"),
                None => String::from("unknown: the state before the sequence's first record"),
            };
            let gap = sp.gap.map_or_else(String::new, |to| {
                format!(
                    "\nRECORDS LOST: the next record starts from {to}, not {}; what happened between is not known",
                    sp.state
                )
            });
            let tip = format!(
                "{}: {} from {} s to {} s ({} µs)\ncause: {cause}{outcome}{gap}",
                s.name,
                sp.state,
                secs(sp.start_us),
                secs(sp.end_us),
                sp.end_us.saturating_sub(sp.start_us),
            );
            let layer = if sp.gap.is_some()
                || matches!(
                    sp.state,
                    State::Paused | State::Aborting | State::Restarting
                ) {
                &mut on_top
            } else {
                &mut data
            };
            gaps |= sp.gap.is_some();
            let gap_class = if sp.gap.is_some() { " gap" } else { "" };
            let _ = write!(
                layer,
                r#"<rect class="span {}{gap_class}" data-t0="{}" data-t1="{}" x="0" y="{y:.1}" width="0" height="{ROW_H}"><title>{}</title></rect>"#,
                state_class(sp.state),
                sp.start_us,
                sp.end_us,
                esc(&tip)
            );
        }
        data.push_str(&on_top);
        data.push_str("</g>");
    }
    // Safety level.
    let _ = write!(
        labels,
        r#"<text class="label level-label" x="8" y="{:.1}">safety level</text>"#,
        level_y + ROW_H - 5.0
    );
    data.push_str(r#"<g class="level-band">"#);
    for (k, l) in run.levels.iter().enumerate() {
        let e = run.levels.get(k + 1).map_or(run.end_us, |n| n.time_us);
        let _ = write!(
            data,
            r#"<rect class="level" data-t0="{}" data-t1="{}" x="0" y="{level_y:.1}" width="0" height="{ROW_H}" fill="{}"><title>{}</title></rect>"#,
            l.time_us,
            e.max(l.time_us),
            level_colour(&l.level),
            esc(&format!(
                "safety level {} from {} s",
                l.level,
                secs(l.time_us)
            ))
        );
    }
    data.push_str("</g>");
    // Markers. Markers of one µs are drawn side by side, 3 px apart, so that none hides
    // another (a monitor firing and its exception sequence not run).
    let requests = run.requests();
    let mut markers: Vec<(&crate::model::Event, &str)> = run
        .events
        .iter()
        .chain(requests.iter())
        .filter_map(|e| {
            let class = match e.kind {
                EventKind::Monitor => "monitor-fire",
                EventKind::Request => "request",
                EventKind::Fault => "fault",
                EventKind::Input => "input",
                EventKind::Exception => "exception",
                EventKind::Failure => "failure",
                EventKind::Move | EventKind::Note => return None,
            };
            Some((e, class))
        })
        .collect();
    markers.sort_by_key(|(e, _)| e.time_us);
    let mut same = 0;
    for (k, (e, class)) in markers.iter().enumerate() {
        same = match k.checked_sub(1).and_then(|p| markers.get(p)) {
            Some((p, _)) if p.time_us == e.time_us => same + 1,
            _ => 0,
        };
        let _ = write!(
            data,
            r#"<line class="marker {class}" data-t="{}" data-dx="{}" x1="0" x2="0" y1="{:.1}" y2="{rows_bottom:.1}"><title>{}</title></line>"#,
            e.time_us,
            3 * same,
            TOP - 6.0,
            esc(&format!("{} s  {}", secs(e.time_us), e.text)),
        );
    }
    // Signals.
    for (k, s) in run.signals.iter().enumerate() {
        let top = sig_top + k as f64 * (SIGNAL_H + SIGNAL_GAP);
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        // The scale of the finite samples: NaN and infinities (a failed sensor) are marked
        // at the plot's middle and edges, and break the line.
        for (_, v) in s.samples.iter().filter(|(_, v)| v.is_finite()) {
            lo = lo.min(*v);
            hi = hi.max(*v);
        }
        if !lo.is_finite() {
            (lo, hi) = (0.0, 1.0);
        }
        if hi - lo < 1e-9 {
            (lo, hi) = (lo - 1.0, hi + 1.0);
        }
        let y = |v: f64| {
            if v.is_nan() {
                top + SIGNAL_H / 2.0
            } else {
                top + (1.0 - (v.clamp(lo, hi) - lo) / (hi - lo)) * SIGNAL_H
            }
        };
        let _ = write!(
            labels,
            r#"<text class="label" x="8" y="{:.1}">{} [{}]</text><text class="scale" x="{:.1}" y="{:.1}">{}</text><text class="scale" x="{:.1}" y="{:.1}">{}</text>"#,
            top + SIGNAL_H / 2.0 + 4.0,
            esc(&s.name),
            esc(&s.unit),
            LABEL_W - 6.0,
            top + 10.0,
            hi,
            LABEL_W - 6.0,
            top + SIGNAL_H,
            lo
        );
        let _ = write!(
            data,
            r#"<rect class="signal-bg" x="0" y="{top:.1}" width="{PLOT_W}" height="{SIGNAL_H}"/>"#
        );
        if lo < 0.0 && hi > 0.0 {
            let _ = write!(
                data,
                r#"<line class="zero" x1="0" x2="{PLOT_W}" y1="{z:.2}" y2="{z:.2}"/>"#,
                z = y(0.0)
            );
        }
        for piece in s.samples.split(|(_, v)| !v.is_finite()) {
            if piece.is_empty() {
                continue;
            }
            let points: Vec<String> = piece
                .iter()
                .map(|(t, v)| format!("{t},{:.2}", y(*v)))
                .collect();
            let _ = write!(
                data,
                r#"<polyline class="signal sig-{}" data-pts="{}" points=""><title>{}</title></polyline>"#,
                crate::vcd::sanitize(&s.name),
                points.join(" "),
                esc(&format!(
                    "{} [{}], {} samples",
                    s.name,
                    s.unit,
                    s.samples.len()
                ))
            );
        }
        for (t, v) in &s.samples {
            let class = if v.is_finite() {
                "sample"
            } else {
                "sample fault"
            };
            let _ = write!(
                data,
                r#"<circle class="{class}" data-t="{t}" cx="0" cy="{:.2}" r="1.6"><title>{} s  {} = {} {}</title></circle>"#,
                y(*v),
                secs(*t),
                esc(&s.name),
                v,
                esc(&s.unit)
            );
        }
    }

    let mut legend = String::new();
    for st in State::ALL.iter().filter(|s| **s != State::Idle) {
        let _ = write!(
            legend,
            r#"<span class="key"><i class="{}"></i>{}</span>"#,
            state_class(*st),
            st
        );
    }
    for l in &levels {
        let _ = write!(
            legend,
            r#"<span class="key"><i style="background:{}"></i>level {}</span>"#,
            level_colour(l),
            esc(l)
        );
    }
    legend.push_str(r#"<span class="key"><b class="m-monitor"></b>monitor fired</span><span class="key"><b class="m-request"></b>request</span><span class="key"><b class="m-fault"></b>fault</span><span class="key"><b class="m-input"></b>critical input</span><span class="key"><b class="m-exception"></b>exception not run</span><span class="key"><b class="m-failure"></b>failure</span>"#);
    if gaps {
        legend.push_str(r#"<span class="key"><i class="s-running gap"></i>records lost</span>"#);
    }

    let warning = run.lost.warning().map_or_else(String::new, |w| {
        format!(
            r#"<div class="lost-warning" role="alert"><b>Warning:</b> {}. Where in time they were is not known; runs and states may be missing anywhere.</div>
"#,
            esc(&w)
        )
    });

    let mut o = String::new();
    let _ = write!(
        o,
        r#"<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{t}</title>
<style>
body {{ font: 13px sans-serif; margin: 10px; color: #222; background: #fff; }}
h1 {{ font-size: 16px; margin: 0 0 6px; }}
.bar {{ margin-bottom: 6px; }} .bar button {{ margin-right: 4px; }}
.key {{ margin-right: 12px; white-space: nowrap; }}
.key i {{ display: inline-block; width: 14px; height: 10px; margin-right: 4px; vertical-align: middle; }}
.key b {{ display: inline-block; width: 3px; height: 12px; margin-right: 4px; vertical-align: middle; }}
.label {{ font-size: 12px; }} .scale {{ font-size: 10px; fill: #666; text-anchor: end; }}
.axis text {{ font-size: 10px; fill: #444; text-anchor: middle; }} .axis line {{ stroke: #ccc; }}
.row-bg {{ fill: #f3f3f3; }} .signal-bg {{ fill: #fafafa; }}
.s-running {{ fill: #2e9b55; background: #2e9b55; }} .s-paused {{ fill: #e6b800; background: #e6b800; }}
.s-aborting {{ fill: #f07c22; background: #f07c22; }} .s-aborted {{ fill: #f1a9a9; background: #f1a9a9; }}
.s-terminated {{ fill: #c9dcf2; background: #c9dcf2; }} .s-restarting {{ fill: #8a4fd8; background: #8a4fd8; }}
.s-idle {{ fill: #f3f3f3; background: #f3f3f3; }}
.gap {{ fill-opacity: 0.35; stroke: #d0021b; stroke-width: 1; stroke-dasharray: 3 2; }}
.key i.gap {{ opacity: 0.35; outline: 1px dashed #d0021b; }}
.marker {{ stroke-width: 2; vector-effect: non-scaling-stroke; }}
.monitor-fire, .m-monitor {{ stroke: #d0021b; background: #d0021b; }}
.request, .m-request {{ stroke: #0057d8; background: #0057d8; stroke-dasharray: 4 3; }}
.exception, .m-exception {{ stroke: #f5a623; background: #f5a623; }} .failure, .m-failure {{ stroke: #7b3f00; background: #7b3f00; }}
.fault, .m-fault {{ stroke: #000; background: #000; }} .input, .m-input {{ stroke: #ff00aa; background: #ff00aa; }}
.signal {{ fill: none; stroke: #1565c0; stroke-width: 1.5; vector-effect: non-scaling-stroke; }}
.zero {{ stroke: #bbb; stroke-width: 1; vector-effect: non-scaling-stroke; }}
.sample {{ fill: #1565c0; opacity: 0; }} .sample:hover {{ opacity: 1; }} .sample.fault {{ fill: #c62828; opacity: 1; }}
.lost-warning {{ margin: 0 0 8px; padding: 6px 10px; background: #fde2e1; border: 2px solid #d0021b; color: #7a0010; font-size: 14px; }}
#tip {{ position: fixed; display: none; background: #ffffe8; border: 1px solid #999; padding: 4px 6px; white-space: pre; font-size: 12px; pointer-events: none; }}
</style></head><body>
<h1>{t}</h1>
{warning}<div class="bar"><button id="zin">zoom in</button><button id="zout">zoom out</button><button id="zall">whole run</button> wheel: zoom at the pointer; drag: pan; hover: details</div>
<div class="bar">{legend}</div>
<svg id="chart" xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height:.0}">
<g class="labels">{labels}</g>
<g class="axis" id="axis"></g>
<svg id="plot" x="{LABEL_W}" y="0" width="{PLOT_W}" height="{height:.0}">{data}</svg>
</svg>
<div id="tip"></div>
<script>
(function () {{
  // Elements carry their times in µs (data-t0/data-t1, data-t, data-pts); each redraw
  // places them in pixels relative to the visible window and clips what lies beyond it,
  // so no coordinate grows large (Blink clamps SVG coordinates near 2^25).
  var END = {end}, H = {height:.0}, LW = {LABEL_W}, PW = {PLOT_W}, AY = {axis_y:.1}, M = 4;
  var plot = document.getElementById('plot'), axis = document.getElementById('axis');
  function all(sel) {{ return Array.prototype.slice.call(plot.querySelectorAll(sel)); }}
  var bars = all('rect[data-t0]').map(function (r) {{
    return {{ el: r, a: +r.getAttribute('data-t0'), b: +r.getAttribute('data-t1'), min: r.classList.contains('span') ? 2 : 0 }};
  }});
  var marks = all('[data-t]').map(function (m) {{
    return {{ el: m, t: +m.getAttribute('data-t'), dx: +(m.getAttribute('data-dx') || 0) }};
  }});
  var lines = all('polyline[data-pts]').map(function (l) {{
    var pts = l.getAttribute('data-pts').split(' ').filter(Boolean).map(function (p) {{
      var c = p.split(','); return [+c[0], +c[1]];
    }});
    return {{ el: l, pts: pts }};
  }});
  var t0 = 0, span = END;
  function clamp() {{ span = Math.max(10, Math.min(END, span)); t0 = Math.max(0, Math.min(END - span, t0)); }}
  function px(t) {{ return (t - t0) / span * PW; }}
  function cut(x) {{ return Math.max(-M, Math.min(PW + M, x)); }}
  function r2(x) {{ return Math.round(x * 100) / 100; }}
  function show(el, on) {{ if (on) el.removeAttribute('display'); else el.setAttribute('display', 'none'); }}
  function draw() {{
    clamp();
    bars.forEach(function (s) {{
      var a = px(s.a), b = Math.max(px(s.b), a + s.min);
      var on = b >= -M && a <= PW + M;
      show(s.el, on);
      if (on) {{ var x = cut(a); s.el.setAttribute('x', r2(x)); s.el.setAttribute('width', r2(Math.max(cut(b) - x, s.min))); }}
    }});
    marks.forEach(function (m) {{
      var x = px(m.t) + m.dx, on = x >= -M && x <= PW + M;
      show(m.el, on);
      if (on) {{
        var a = m.el.tagName === 'circle' ? ['cx'] : ['x1', 'x2'];
        a.forEach(function (k) {{ m.el.setAttribute(k, r2(x)); }});
      }}
    }});
    lines.forEach(function (l) {{
      // The visible samples and one on either side, the outer segments cut at the edges.
      var p = l.pts, lo = 0, hi = p.length, q = [];
      while (lo < hi) {{ var mid = (lo + hi) >> 1; if (p[mid][0] < t0) lo = mid + 1; else hi = mid; }}
      for (var i = Math.max(0, lo - 1); i < p.length; i++) {{
        q.push([px(p[i][0]), p[i][1]]);
        if (q[q.length - 1][0] > PW + M) break;
      }}
      function edge(a, b, e) {{ return [e, a[1] + (b[1] - a[1]) * (e - a[0]) / (b[0] - a[0])]; }}
      var n = q.length;
      if (n > 1 && q[0][0] < -M) q[0] = edge(q[0], q[1], -M);
      if (n > 1 && q[n - 1][0] > PW + M) q[n - 1] = edge(q[n - 2], q[n - 1], PW + M);
      l.el.setAttribute('points', q.map(function (c) {{ return r2(cut(c[0])) + ',' + c[1]; }}).join(' '));
    }});
    var raw = span / 8, p = Math.pow(10, Math.floor(Math.log10(raw))), step = p;
    [1, 2, 5, 10].forEach(function (m) {{ if (p * m <= raw) step = p * m; }});
    var s = '';
    for (var t = Math.ceil(t0 / step) * step; t <= t0 + span; t += step) {{
      var x = r2(LW + (t - t0) / span * PW);
      var d = step >= 1e6 ? 0 : Math.min(6, Math.ceil(6 - Math.log10(step)));
      s += '<line x1="' + x + '" x2="' + x + '" y1="' + (AY - 4) + '" y2="' + H + '"/>' +
           '<text x="' + x + '" y="' + (AY - 7) + '">' + (t / 1e6).toFixed(d) + ' s</text>';
    }}
    axis.innerHTML = s;
  }}
  function zoom(f, at) {{ var c = t0 + at * span; span = span * f; clamp(); t0 = c - at * span; draw(); }}
  plot.addEventListener('wheel', function (e) {{
    e.preventDefault();
    var r = plot.getBoundingClientRect();
    zoom(e.deltaY < 0 ? 0.8 : 1.25, (e.clientX - r.left) / r.width);
  }}, {{ passive: false }});
  var drag = null;
  plot.addEventListener('mousedown', function (e) {{ drag = {{ x: e.clientX, t: t0 }}; }});
  window.addEventListener('mouseup', function () {{ drag = null; }});
  var tip = document.getElementById('tip');
  window.addEventListener('mousemove', function (e) {{
    if (drag) {{ t0 = drag.t - (e.clientX - drag.x) / PW * span; draw(); }}
    var el = e.target, title = el && el.querySelector ? el.querySelector('title') : null;
    if (title && !drag) {{
      tip.textContent = title.textContent; tip.style.display = 'block';
      tip.style.left = (e.clientX + 14) + 'px'; tip.style.top = (e.clientY + 10) + 'px';
    }} else {{ tip.style.display = 'none'; }}
  }});
  document.getElementById('zin').onclick = function () {{ zoom(0.5, 0.5); }};
  document.getElementById('zout').onclick = function () {{ zoom(2, 0.5); }};
  document.getElementById('zall').onclick = function () {{ t0 = 0; span = END; draw(); }};
  // `page.html#t=2.4,2.8` opens on that window (seconds; read to the µs exactly).
  function us(v) {{ var d = v.split('.'); return +d[0] * 1e6 + +((d[1] || '') + '000000').slice(0, 6); }}
  var m = /t=([0-9]+(?:\.[0-9]*)?),([0-9]+(?:\.[0-9]*)?)/.exec(location.hash);
  if (m) {{ t0 = us(m[1]); span = us(m[2]) - t0; }}
  draw();
}})();
</script>
</body></html>
"#,
        t = esc(title),
        axis_y = TOP,
    );
    o
}
