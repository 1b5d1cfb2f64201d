//! What the command line shows while a job runs: a progress bar per phase on a terminal
//! (nothing on a pipe), a summary line when a phase ends, the job's notes and warnings.
//! `--quiet` (or `--log-level warn`) keeps only the warnings, `--log-level error` none.

use indicatif::{ProgressBar, ProgressStyle};
use raylink::Progress;
use std::io::IsTerminal;
use std::sync::Mutex;

pub struct Terminal {
    quiet: bool,
    bars: bool,
    bar: Mutex<Option<ProgressBar>>,
}

impl Terminal {
    pub fn new(quiet: bool) -> Terminal {
        Terminal {
            quiet,
            bars: !quiet && std::io::stderr().is_terminal(),
            bar: Mutex::new(None),
        }
    }

    /// Prints a line above the bar in hand (or plainly).
    fn line(&self, text: &str) {
        match &*self.bar.lock().unwrap_or_else(|e| e.into_inner()) {
            Some(bar) => bar.suspend(|| eprintln!("{text}")),
            None => eprintln!("{text}"),
        }
    }
}

impl Progress for Terminal {
    fn begin(&self, phase: &str, total: Option<u64>, unit: &str) {
        if !self.bars {
            return;
        }
        let bar = match total {
            Some(n) => {
                let bar = ProgressBar::new(n);
                bar.set_style(
                    ProgressStyle::with_template(&format!(
                        "{{spinner}} {phase} [{{elapsed_precise}}] {{wide_bar}} {{human_pos}}/{{human_len}} \
                         {unit}, ETA {{eta}} {{msg}}"
                    ))
                    .expect("the progress template is valid"),
                );
                bar
            }
            None => {
                let bar = ProgressBar::new_spinner();
                bar.set_style(
                    ProgressStyle::with_template(&if unit.is_empty() {
                        format!("{{spinner}} {phase} [{{elapsed_precise}}] {{msg}}")
                    } else {
                        format!("{{spinner}} {phase} [{{elapsed_precise}}] {{human_pos}} {unit} {{msg}}")
                    })
                    .expect("the progress template is valid"),
                );
                bar
            }
        };
        bar.enable_steady_tick(std::time::Duration::from_millis(200));
        if let Some(old) = self
            .bar
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .replace(bar)
        {
            old.finish_and_clear();
        }
    }

    fn advance(&self, units: u64) {
        if let Some(bar) = &*self.bar.lock().unwrap_or_else(|e| e.into_inner()) {
            bar.inc(units);
        }
    }

    fn status(&self, text: &str) {
        if let Some(bar) = &*self.bar.lock().unwrap_or_else(|e| e.into_inner()) {
            bar.set_message(text.to_string());
        }
    }

    fn end(&self, phase: &str, seconds: f64, summary: &str) {
        if let Some(bar) = self.bar.lock().unwrap_or_else(|e| e.into_inner()).take() {
            bar.finish_and_clear();
        }
        // The render's own summary is printed once the image is written; short phases other
        // than a technique's preparation pass without a line.
        let preparation = matches!(phase, "overture" | "preprocess" | "distribution");
        if !self.quiet
            && phase != "render"
            && !summary.is_empty()
            && (preparation || seconds >= 1.0)
        {
            self.line(&format!("{phase}: {summary} ({seconds:.2} s)"));
        }
    }

    fn note(&self, line: &str) {
        if !self.quiet {
            self.line(line);
        }
    }

    fn warn(&self, line: &str) {
        if crate::log::enabled(crate::log::Level::Warn) {
            self.line(&format!("raylink: warning: {line}"));
        }
    }
}
