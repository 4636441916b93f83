//! The stop tests of the force loops: nodes that no longer move (the seed's dptol), and a
//! quality that no longer rises (a truss with density control may never come to rest).

/// Whether every node moved less than `dptol` (relative to its size) in a step: the seed's
/// stop test, trusted only after the first `warmup` iterations (the start's first steps may
/// be small while density control has yet to act).
#[inline]
pub(crate) fn at_rest(max_move: f64, dptol: f64, iter: usize, warmup: usize) -> bool {
    max_move < dptol && iter > warmup
}

/// How [`Plateau`] judges the last windows.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Rule {
    /// Each of the last `windows` windows raised the best quality by less than `min_gain`.
    EveryWindow,
    /// The last `windows` windows together raised it by less than `windows * min_gain`.
    OverSpan,
    /// No window of the last `windows` rose by `min_gain` above the last mark, the last value
    /// that did (the first mark is the value before the first window).
    SinceMark,
}

/// A quality plateau: fed the mesh quality once per window, it reports when the quality
/// stopped rising by `min_gain` per window over the last `windows` windows, by one of three
/// rules: [`Plateau::every_window`] (patient: one window's gain starts the count again),
/// [`Plateau::over_span`] (the mean gain over the span) or [`Plateau::since_mark`] (a gain
/// counts only once it adds up to `min_gain` above the last mark).
#[derive(Clone, Debug)]
pub(crate) struct Plateau {
    rule: Rule,
    min_gain: f64,
    windows: usize,
    best: Vec<f64>,
    stalled: usize,
    /// For `SinceMark`: the mark and the window it was set at.
    mark: (f64, usize),
}

impl Plateau {
    /// Plateau when each of `windows` windows in a row gained less than `min_gain`.
    pub(crate) fn every_window(min_gain: f64, windows: usize) -> Self {
        Plateau { rule: Rule::EveryWindow, min_gain, windows, best: Vec::new(), stalled: 0, mark: (0.0, 0) }
    }
    /// Plateau when the last `windows` windows gained less than `windows * min_gain` in all.
    pub(crate) fn over_span(min_gain: f64, windows: usize) -> Self {
        Plateau { rule: Rule::OverSpan, min_gain, windows, best: Vec::new(), stalled: 0, mark: (0.0, 0) }
    }
    /// Plateau when no window of the last `windows` rose by `min_gain` above the last mark;
    /// `start` is the quality before the first window.
    pub(crate) fn since_mark(min_gain: f64, windows: usize, start: f64) -> Self {
        Plateau { rule: Rule::SinceMark, min_gain, windows, best: Vec::new(), stalled: 0, mark: (start, 0) }
    }
    /// Records the quality of one window; true when the quality has reached its plateau.
    pub(crate) fn reached(&mut self, q: f64) -> bool {
        let before = self.best.last().copied();
        self.best.push(before.map_or(q, |b| b.max(q)));
        match self.rule {
            Rule::EveryWindow => {
                // The first window is measured against zero, as a run starts from nothing.
                if q - before.unwrap_or(0.0) < self.min_gain {
                    self.stalled += 1;
                } else {
                    self.stalled = 0;
                }
                self.stalled >= self.windows
            }
            Rule::SinceMark => {
                let n = self.best.len();
                if q > self.mark.0 + self.min_gain {
                    self.mark = (q, n);
                }
                n >= self.mark.1 + self.windows
            }
            Rule::OverSpan => {
                let n = self.best.len();
                n > self.windows
                    && self.best[n - 1] - self.best[n - 1 - self.windows] < self.windows as f64 * self.min_gain
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_rising_quality_is_no_plateau_and_a_flat_one_is() {
        for mut p in [Plateau::every_window(1e-3, 3), Plateau::over_span(1e-3, 3)] {
            for k in 0..10 {
                assert!(!p.reached(0.5 + 0.01 * k as f64));
            }
            let hits: Vec<bool> = (0..4).map(|_| p.reached(0.6)).collect();
            assert_eq!(hits, [false, false, false, true]);
        }
    }

    #[test]
    fn small_gains_count_since_the_mark_only_once_they_add_up() {
        let mut p = Plateau::since_mark(1e-3, 3, 0.5);
        // 0.5004, 0.5008 stay within 1e-3 of the mark 0.5; 0.5012 passes it at window 3.
        assert_eq!([0.5004, 0.5008, 0.5012].map(|q| p.reached(q)), [false, false, false]);
        // Three windows without a gain past 0.5022: a plateau at the third.
        assert_eq!([0.5013, 0.5014, 0.5015].map(|q| p.reached(q)), [false, false, true]);
    }

    #[test]
    fn one_rising_window_restarts_the_patient_count_only() {
        let (mut every, mut span) = (Plateau::every_window(1e-3, 3), Plateau::over_span(1e-3, 3));
        for q in [0.5, 0.6, 0.6, 0.6] {
            every.reached(q);
            span.reached(q);
        }
        // A gain of 2e-3 after two flat windows: the span's mean gain is below 1e-3 a window.
        assert!(!every.reached(0.602));
        assert!(span.reached(0.602));
    }
}
