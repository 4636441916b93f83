//! Step control: a forward Euler step (seed eq. 2.4) never inverts an element. The seed's
//! global retriangulation repairs inverted elements after the fact; a mesh kept by local
//! operations must never hold one, so a step that would invert an element is shortened.

use super::force::TrussPoint;
use super::parallel::CHUNK;
use rayon::prelude::*;

/// How often a vertex of rejected elements steps back in one round of [`guard_inversions`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Backoff {
    /// Once for each rejected element it belongs to (the more rejected, the shorter the step).
    PerElement,
    /// Once per round, however many rejected elements it belongs to.
    PerRound,
}

/// Batch step control after a Jacobi step from `old` to `newp`: every vertex of an element
/// that `positive` rejects steps back halfway (as often as `backoff` says), at most
/// `max_halvings` times in all (then back to its old position), until every element is
/// positive. Only the elements in `subset` (indices
/// into `cells`) are checked when given (the others have no vertex that moved). The old
/// positions are valid, so this ends. `positive` is an exact orientation test.
pub(crate) fn guard_inversions<P: TrussPoint, const N: usize>(
    cells: &[[u32; N]],
    subset: Option<&[u32]>,
    old: &[P],
    newp: &mut [P],
    max_halvings: u8,
    backoff: Backoff,
    positive: impl Fn(&[P], &[u32; N]) -> bool + Sync,
) {
    let all: Vec<u32>;
    let subset = match subset {
        Some(s) => s,
        None => {
            all = (0..cells.len() as u32).collect();
            &all
        }
    };
    let scan = |newp: &[P], moved: Option<&[bool]>| -> Vec<u32> {
        subset
            .par_iter()
            .with_min_len(CHUNK)
            .copied()
            .filter(|&k| {
                let c = &cells[k as usize];
                moved.is_none_or(|m| c.iter().any(|&i| m[i as usize])) && !positive(newp, c)
            })
            .collect()
    };
    let mut bad = scan(newp, None);
    if bad.is_empty() {
        return;
    }
    let mut halvings = vec![0u8; old.len()];
    let mut moved = vec![false; old.len()];
    while !bad.is_empty() {
        let mut hit: Vec<u32> = bad.iter().flat_map(|&k| cells[k as usize]).collect();
        hit.sort_unstable();
        if backoff == Backoff::PerRound {
            hit.dedup();
        }
        let mut touched = false;
        for i in hit {
            let i = i as usize;
            if newp[i] == old[i] {
                continue;
            }
            touched = true;
            halvings[i] += 1;
            newp[i] = if halvings[i] > max_halvings { old[i] } else { old[i] + (newp[i] - old[i]) * 0.5 };
            moved[i] = true;
        }
        if !touched {
            // Every vertex of every rejected element is back where it was: impossible from a
            // valid start, but never loop.
            return;
        }
        // Only the elements of vertices just moved back can have changed sign.
        bad = scan(newp, Some(&moved));
        moved.iter_mut().for_each(|x| *x = false);
    }
}

/// Sequential step control for one node (Gauss-Seidel steps, checked moves): tries `new`,
/// then steps from `old` toward it of half, a quarter, ... of the way (`max_halvings` of
/// them), and returns the first position `accept` takes (`accept` makes the move, e.g. a
/// checked relocation), or `None` when it takes none.
pub(crate) fn backtrack<P: TrussPoint, E>(
    old: P,
    new: P,
    max_halvings: u32,
    mut accept: impl FnMut(P) -> Result<bool, E>,
) -> Result<Option<P>, E> {
    if accept(new)? {
        return Ok(Some(new));
    }
    let mut t = 1.0;
    for _ in 0..max_halvings {
        t *= 0.5;
        let y = old + (new - old) * t;
        if accept(y)? {
            return Ok(Some(y));
        }
    }
    Ok(None)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::predicates::{orient2d, Sign};
    use glam::DVec2;

    fn positive(p: &[DVec2], t: &[u32; 3]) -> bool {
        orient2d(p[t[0] as usize], p[t[1] as usize], p[t[2] as usize]) == Sign::Positive
    }

    #[test]
    fn a_step_through_the_opposite_edge_is_shortened() {
        let tris = [[0u32, 1, 2]];
        let old = [DVec2::ZERO, DVec2::X, DVec2::Y];
        // Vertex 2 jumps below the edge 0-1: halved twice it is above again.
        let mut newp = [DVec2::ZERO, DVec2::X, DVec2::new(0.0, -2.0)];
        guard_inversions(&tris, None, &old, &mut newp, 6, Backoff::PerRound, positive);
        assert!(positive(&newp, &tris[0]));
        assert_eq!(newp[2], DVec2::new(0.0, 0.25));
        // With no halving allowed it goes back.
        let mut newp = [DVec2::ZERO, DVec2::X, DVec2::new(0.0, -2.0)];
        guard_inversions(&tris, None, &old, &mut newp, 0, Backoff::PerElement, positive);
        assert_eq!(newp[2], old[2]);
    }

    #[test]
    fn backtrack_takes_the_first_accepted_step() {
        let r: Result<_, ()> = backtrack(DVec2::ZERO, DVec2::new(4.0, 0.0), 3, |y| Ok(y.x <= 1.0));
        assert_eq!(r, Ok(Some(DVec2::new(1.0, 0.0))));
        let r: Result<_, ()> = backtrack(DVec2::ZERO, DVec2::new(4.0, 0.0), 1, |y| Ok(y.x <= 1.0));
        assert_eq!(r, Ok(None));
    }
}
