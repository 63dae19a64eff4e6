//! Progress as the command line shows it: a bar on a terminal, a line per frame on
//! standard output otherwise (a log, a farm's output file).

use std::io::IsTerminal;
use std::sync::Arc;

use activeskin::frames::{Progress, Report};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// The frame loop's reports, shown.
pub fn shown() -> Progress {
    if !std::io::stderr().is_terminal() {
        return Progress {
            each: Arc::new(|report| {
                if let Report::Frame {
                    frame,
                    stats,
                    milliseconds,
                } = report
                {
                    println!(
                        "frame {frame}: {} sub-steps, {} band nodes, area {:.4}, volume {:.4}, χ {}, {} component(s), {milliseconds:.0} ms",
                        stats.substeps,
                        stats.band_nodes,
                        stats.area,
                        stats.volume,
                        stats.euler_characteristic,
                        stats.components,
                    );
                }
            }),
            topology: true,
        };
    }
    let bar = ProgressBar::with_draw_target(None, ProgressDrawTarget::hidden());
    Progress {
        each: Arc::new(move |report| match *report {
            Report::Start { first, last } => {
                bar.set_length((last - first + 1).max(0) as u64);
                bar.set_style(
                    ProgressStyle::with_template(
                        "{bar:40} {pos}/{len} frames, {elapsed} ({eta} left) {msg}",
                    )
                    .expect("a valid progress template"),
                );
                bar.set_draw_target(ProgressDrawTarget::stderr());
                bar.reset();
            }
            Report::Skipped { frames } => bar.inc(frames),
            Report::Frame { .. } => bar.inc(1),
            Report::Done => bar.finish_and_clear(),
        }),
        topology: false,
    }
}
