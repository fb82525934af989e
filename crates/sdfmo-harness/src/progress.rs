//! Progress bars: drawn on stderr only when stderr is a terminal, invisible otherwise.

use std::io::IsTerminal;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// Resolution of a fractional progress bar (the builder reports a fraction in [0, 1]).
const FRACTION_STEPS: u64 = 1000;

/// A bar over `len` steps with a message, or a hidden one when stderr is not a terminal.
pub fn steps(len: u64, message: &str) -> ProgressBar {
    styled(len, "{pos}/{len}", message)
}

/// A bar driven by a fraction in [0, 1] (see [`set_fraction`]).
pub fn fraction(message: &str) -> ProgressBar {
    styled(FRACTION_STEPS, "{percent:>3}%", message)
}

/// A bar over `len` steps showing `count` (an indicatif template fragment) after the bar.
fn styled(len: u64, count: &str, message: &str) -> ProgressBar {
    let bar = new_bar(len);
    let template = format!("{{spinner}} [{{elapsed_precise}}] {{bar:30}} {count} {{msg}}");
    if let Ok(style) = ProgressStyle::with_template(&template) {
        bar.set_style(style);
    }
    bar.set_message(message.to_owned());
    bar
}

/// Moves a [`fraction`] bar to `f` (clamped to [0, 1]; NaN counts as 0).
pub fn set_fraction(bar: &ProgressBar, f: f32) {
    let f = if f.is_nan() { 0.0 } else { f.clamp(0.0, 1.0) };
    bar.set_position((f64::from(f) * FRACTION_STEPS as f64).round() as u64);
}

fn new_bar(len: u64) -> ProgressBar {
    if std::io::stderr().is_terminal() {
        let bar = ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::stderr());
        // Redraw on a timer so the elapsed time moves during long single steps (a deep build).
        bar.enable_steady_tick(std::time::Duration::from_millis(200));
        bar
    } else {
        ProgressBar::hidden()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fraction_is_clamped() {
        let bar = fraction("x");
        set_fraction(&bar, 2.0);
        assert_eq!(bar.position(), FRACTION_STEPS);
        set_fraction(&bar, f32::NAN);
        assert_eq!(bar.position(), 0);
        set_fraction(&bar, 0.5);
        assert_eq!(bar.position(), FRACTION_STEPS / 2);
    }
}
