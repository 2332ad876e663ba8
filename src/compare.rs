//! Side by side (`--compare`): one scene in 2 to 4 panes, each its own [`World`] with
//! its own solver settings, stepped in lock step. A [`Pane`] keeps the figures its label
//! shows: ms per step, the deepest penetration, the joint error and the energy drift
//! since the start. Drawing the panes is the renderer's (`render::compare`) and the
//! window's business; this part needs no feature.

use crate::world::{StepError, World};

/// The fewest panes of a comparison.
pub const MIN_PANES: usize = 2;
/// The most panes of a comparison.
pub const MAX_PANES: usize = 4;

/// One pane: its settings as given (the label), its world and what its steps measured.
pub struct Pane {
    /// The settings as typed after `--compare`, shown at the pane's top.
    pub label: String,
    /// The pane's world.
    pub world: World,
    /// The energy when the pane started (J).
    energy_start: f64,
    /// Milliseconds of the steps so far, and their count.
    step_ms: f64,
    steps: u64,
    /// The mean ms per step of the last [`Pane::STEP_WINDOW`] steps (or all so far).
    recent_ms: f64,
    recent_steps: u64,
    shown_ms: Option<f64>,
}

/// The figures a pane's label shows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Figures {
    /// Mean wall time of a step (ms), over the last steps; `None` before the first.
    pub ms_per_step: Option<f64>,
    /// The deepest overlap of the last step (m).
    pub penetration: f32,
    /// The largest joint anchor separation now (m); `None` for a world without joints.
    pub joint_error: Option<f32>,
    /// (E - E0) / |E0|: the energy's change since the start, relative; `None` when the
    /// start's energy is 0.
    pub energy_drift: Option<f64>,
}

impl Pane {
    /// Steps averaged for the ms per step shown.
    pub const STEP_WINDOW: u64 = 30;

    /// A pane on a freshly built world.
    pub fn new(label: impl Into<String>, world: World) -> Pane {
        Pane {
            label: label.into(),
            energy_start: world.energy(),
            world,
            step_ms: 0.0,
            steps: 0,
            recent_ms: 0.0,
            recent_steps: 0,
            shown_ms: None,
        }
    }

    /// Steps the world once, timing the step.
    pub fn step(&mut self) -> Result<(), StepError> {
        let t = std::time::Instant::now();
        self.world.step()?;
        let ms = t.elapsed().as_secs_f64() * 1e3;
        self.step_ms += ms;
        self.steps += 1;
        self.recent_ms += ms;
        self.recent_steps += 1;
        if self.recent_steps >= Self::STEP_WINDOW || self.shown_ms.is_none() {
            self.shown_ms = Some(self.recent_ms / self.recent_steps as f64);
            if self.recent_steps >= Self::STEP_WINDOW {
                self.recent_ms = 0.0;
                self.recent_steps = 0;
            }
        }
        Ok(())
    }

    /// Steps taken.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// Mean ms per step over all steps so far (`None` before the first).
    pub fn mean_ms(&self) -> Option<f64> {
        (self.steps > 0).then(|| self.step_ms / self.steps as f64)
    }

    /// Starts the energy drift again from now (after a reset or a drag, say).
    pub fn restart_energy(&mut self) {
        self.energy_start = self.world.energy();
    }

    /// The figures now.
    pub fn figures(&self) -> Figures {
        let e = self.world.energy();
        Figures {
            ms_per_step: self.shown_ms,
            penetration: if self.steps > 0 {
                self.world.stats().penetration
            } else {
                0.0
            },
            joint_error: (!self.world.joints.is_empty()).then(|| self.world.joint_error()),
            energy_drift: (self.energy_start.abs() > 1e-9)
                .then(|| (e - self.energy_start) / self.energy_start.abs()),
        }
    }

    /// The label's lines: the settings, then the figures (see [`figure_lines`]).
    pub fn label_lines(&self) -> Vec<String> {
        let mut lines = vec![self.label.clone()];
        lines.extend(figure_lines(&self.figures()));
        lines
    }
}

/// The figures as two short lines, e.g. `0.412 ms/step  pen 1.20 mm` and
/// `joint -  energy -0.31%` (a dash where a figure does not apply).
pub fn figure_lines(f: &Figures) -> [String; 2] {
    let ms = f
        .ms_per_step
        .map_or_else(|| "- ms/step".to_owned(), |ms| format!("{ms:.3} ms/step"));
    let joint = f
        .joint_error
        .map_or_else(|| "-".to_owned(), |j| format!("{:.2} mm", j * 1e3));
    let energy = f
        .energy_drift
        .map_or_else(|| "-".to_owned(), |d| format!("{:+.2}%", d * 100.0));
    [
        format!("{ms}  pen {:.2} mm", f.penetration * 1e3),
        format!("joint {joint}  energy {energy}"),
    ]
}

/// `text` cut into lines of at most `width` characters at spaces (a word longer than
/// `width` gets a line of its own), so a pane's label fits its pane.
pub fn wrap(text: &str, width: usize) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    for word in text.split_whitespace() {
        match lines.last_mut() {
            Some(line) if line.chars().count() + 1 + word.chars().count() <= width => {
                line.push(' ');
                line.push_str(word);
            }
            _ => lines.push(word.to_owned()),
        }
    }
    lines
}

/// Splits a `--compare` value into words at whitespace (no quoting: no setting's value
/// holds a space).
pub fn split_words(s: &str) -> Vec<String> {
    s.split_whitespace().map(str::to_owned).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_label_wraps_at_spaces_to_the_width() {
        let lines = wrap("--solver pgs --substeps 1 --iterations 10", 16);
        assert_eq!(lines, ["--solver pgs", "--substeps 1", "--iterations 10"]);
        assert!(lines.iter().all(|l| l.len() <= 16));
        assert_eq!(
            wrap("--joint-damping-ratio 5", 8),
            ["--joint-damping-ratio", "5"]
        );
        assert_eq!(wrap("a b c", 80), ["a b c"]);
    }

    #[test]
    fn figure_lines_show_dashes_where_a_figure_does_not_apply() {
        let f = Figures {
            ms_per_step: None,
            penetration: 0.0012,
            joint_error: None,
            energy_drift: None,
        };
        assert_eq!(
            figure_lines(&f),
            [
                "- ms/step  pen 1.20 mm".to_owned(),
                "joint -  energy -".to_owned()
            ]
        );
        let f = Figures {
            ms_per_step: Some(0.4123),
            penetration: 0.0,
            joint_error: Some(0.00025),
            energy_drift: Some(-0.0031),
        };
        assert_eq!(
            figure_lines(&f),
            [
                "0.412 ms/step  pen 0.00 mm".to_owned(),
                "joint 0.25 mm  energy -0.31%".to_owned()
            ]
        );
    }

    #[test]
    fn words_split_at_any_whitespace() {
        assert_eq!(
            split_words("  --solver pgs\t--iterations 4 "),
            ["--solver", "pgs", "--iterations", "4"]
        );
    }
}
