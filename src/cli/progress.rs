//! Progress display on stderr (indicatif): a spinner for a render, a bar over the steps of a
//! benchmark or an animation. Drawn only when stderr is a terminal.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use render::whitted::Progress;
use std::time::Duration;

/// A progress display; `render`'s stages name its message.
pub struct Bar(pub ProgressBar);

impl Progress for Bar {
    fn stage(&self, name: &str) {
        self.0.set_message(name.to_string());
    }
}

/// A bar over `n` steps; `Bar::stage` advances it.
pub fn step_bar(n: u64) -> Bar {
    let pb = ProgressBar::with_draw_target(Some(n), ProgressDrawTarget::stderr());
    pb.set_style(
        ProgressStyle::with_template("{bar:30} {pos}/{len} [{elapsed}, eta {eta}] {msg}").unwrap(),
    );
    pb.enable_steady_tick(Duration::from_millis(200));
    Bar(pb)
}

impl Bar {
    pub fn step(&self, name: &str) {
        if self.0.position() < self.0.length().unwrap_or(0) && !self.0.message().is_empty() {
            self.0.inc(1);
        }
        self.0.set_message(name.to_string());
    }
}

pub fn progress_bar() -> Bar {
    // Drawn only when stderr is a terminal (indicatif hides it otherwise).
    let pb = ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr());
    pb.set_style(ProgressStyle::with_template("{spinner} [{elapsed}] {msg}").unwrap());
    pb.enable_steady_tick(Duration::from_millis(120));
    Bar(pb)
}
