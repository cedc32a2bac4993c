//! How long the HTML timeline takes for one sequence with many runs (a periodic sequence of
//! a long simulation): prints the figures, asserts nothing about them.
//!
//! ```sh
//! cargo run --release -p rtseq-trace --example html_scale            # 8 000, 32 000, 100 000 runs
//! cargo run --release -p rtseq-trace --example html_scale -- 1000000
//! ```

use std::time::Instant;

use rtseq_trace::{html, tracefile};

/// A trace file of one sequence started every ms and completing 0.5 ms later, `runs` times.
fn trace(runs: u64) -> String {
    let mut text = String::from(
        r#"{"format":"rtseq-trace","version":1,"time_unit":"us","end":0,"sequences":[{"id":0,"name":"move","caller":null}],"monitors":[]}"#,
    );
    text.push('\n');
    for k in 0..runs {
        let t = k * 1000;
        text.push_str(&format!(
            "{{\"t\":{t},\"seq\":0,\"from\":\"Idle\",\"to\":\"Running\",\"cause\":\"start\"}}\n"
        ));
        text.push_str(&format!(
            "{{\"t\":{},\"seq\":0,\"from\":\"Running\",\"to\":\"Terminated\",\"cause\":\"completed\"}}\n",
            t + 500
        ));
    }
    text
}

fn main() {
    let sizes: Vec<u64> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let sizes = if sizes.is_empty() {
        vec![8_000, 32_000, 100_000]
    } else {
        sizes
    };
    for runs in sizes {
        let text = trace(runs);
        let t0 = Instant::now();
        let run = match tracefile::read(&text) {
            Ok(run) => run,
            Err(e) => {
                eprintln!("{runs} runs: {e}");
                continue;
            }
        };
        let read = t0.elapsed();
        let t1 = Instant::now();
        let page = html::render(&run, "runs");
        let render = t1.elapsed();
        println!(
            "{runs:>8} runs: read {:>8.1} ms, HTML render {:>9.1} ms ({} MB)",
            read.as_secs_f64() * 1e3,
            render.as_secs_f64() * 1e3,
            page.len() / 1_000_000
        );
    }
}
