//! Progress reporting: a bar on a terminal, JSON lines for the Blender add-on and farm
//! tools, or nothing.

use crate::bake::Progress;
use clap::ValueEnum;
use indicatif::{ProgressBar, ProgressStyle};
use std::io::{IsTerminal, Write};

/// Writes `text` to stdout. A closed pipe (`beeswarm … | head`) is not worth a panic: the
/// reader has gone, so the text is dropped and the command carries on.
pub fn stdout(text: &str) {
    let mut out = std::io::stdout().lock();
    let _ = out.write_all(text.as_bytes());
    let _ = out.flush();
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Mode {
    /// A bar when stderr is a terminal, otherwise nothing.
    Auto,
    /// A progress bar with ETA on stderr.
    Bar,
    /// One JSON object per line on stdout.
    Json,
    /// No progress output.
    None,
}

pub struct Reporter {
    mode: Mode,
    bar: Option<ProgressBar>,
}

impl Reporter {
    pub fn new(mode: Mode, total: usize, quiet: bool) -> Self {
        let mode = match mode {
            Mode::Auto if quiet || !std::io::stderr().is_terminal() => Mode::None,
            Mode::Auto => Mode::Bar,
            m => m,
        };
        let bar = (mode == Mode::Bar).then(|| {
            let b = ProgressBar::new(total as u64);
            b.set_style(
                ProgressStyle::with_template(
                    "{spinner} frame {msg} [{bar:40}] {pos}/{len} {elapsed_precise} ETA {eta}",
                )
                .expect("valid template")
                .progress_chars("=> "),
            );
            b
        });
        Reporter { mode, bar }
    }

    pub fn mode(&self) -> Mode {
        self.mode
    }

    pub fn update(&mut self, p: Progress) {
        match self.mode {
            Mode::Json => {
                let mut out = std::io::stdout().lock();
                let _ = writeln!(
                    out,
                    "{{\"event\":\"progress\",\"frame\":{},\"done\":{},\"total\":{},\"elapsed_s\":{:.3}}}",
                    p.frame, p.done, p.total, p.elapsed_s
                );
                let _ = out.flush();
            }
            Mode::Bar => {
                if let Some(b) = &self.bar {
                    b.set_position(p.done as u64);
                    b.set_message(p.frame.to_string());
                }
            }
            _ => {}
        }
    }

    pub fn finish(&mut self, outputs: &[std::path::PathBuf]) {
        if let Some(b) = self.bar.take() {
            b.finish_and_clear();
        }
        if self.mode == Mode::Json {
            let list: Vec<String> = outputs
                .iter()
                .map(|p| {
                    std::path::absolute(p)
                        .unwrap_or_else(|_| p.clone())
                        .display()
                        .to_string()
                })
                .collect();
            stdout(&format!(
                "{}\n",
                serde_json::json!({ "event": "done", "outputs": list })
            ));
        }
    }

    pub fn abandon(&mut self) {
        if let Some(b) = self.bar.take() {
            b.abandon();
        }
    }
}
