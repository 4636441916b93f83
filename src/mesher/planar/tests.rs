use super::*;
use proptest::prelude::*;

proptest! {
    /// The square-root-free bound never passes a triangle below the repair threshold.
    #[test]
    fn repair_bound_is_safe(c in prop::array::uniform6(-1.0f64..1.0)) {
        let [a, b, c] = [DVec2::new(c[0], c[1]), DVec2::new(c[2], c[3]), DVec2::new(c[4], c[5])];
        if surely_not_below_repair(a, b, c) {
            prop_assert!(crate::quality::triangle_q([a, b, c]) >= Q_REPAIR);
        }
    }
}

#[test]
fn repair_bound_passes_good_triangles_and_not_slivers() {
    let eq = [DVec2::ZERO, DVec2::X, DVec2::new(0.5, 0.75f64.sqrt())];
    assert!(surely_not_below_repair(eq[0], eq[1], eq[2]));
    let sliver = [DVec2::ZERO, DVec2::X, DVec2::new(0.5, 1e-3)];
    assert!(crate::quality::triangle_q(sliver) < Q_REPAIR);
    assert!(!surely_not_below_repair(sliver[0], sliver[1], sliver[2]));
}

/// The iteration cap returns a mesh at least as good, by the smallest quality, as every state
/// the force loop met before it (issue: the cap kept the last state, not the best).
#[test]
fn iteration_cap_returns_the_best_state_met() {
    use crate::geometry::{Circle, Difference, Rectangle};
    let domain = Difference::new(Rectangle::new([-1.0, -1.0], [1.0, 1.0]), Circle::new([0.0, 0.0], 0.4));
    println!("| cap | kept iteration | best state q min | returned q min |");
    println!("|---|---|---|---|");
    let mut restored = 0;
    for cap in [20, 40, 60, 80, 120, 160, 240] {
        let opts = Options2::uniform(0.1, [-1.0, -1.0], [1.0, 1.0])
            .with_size(|p: DVec2| (4.0 * p.length() - 1.0).min(2.0))
            .with_fixed(vec![[-1.0, -1.0], [-1.0, 1.0], [1.0, -1.0], [1.0, 1.0]])
            .with_max_iter(cap);
        best::OFFERED.with(|o| o.borrow_mut().clear());
        let out = run(&domain, &opts).expect("meshing");
        let offered = best::OFFERED.with(|o| o.borrow().clone());
        let best_q = offered.iter().map(|s| s.1).fold(f64::NEG_INFINITY, f64::max);
        let q = out.report.quality.q_min;
        println!("| {cap} | {:?} | {best_q:.4} | {q:.4} |", out.report.kept_iteration);
        assert!(!offered.is_empty(), "cap {cap}: no state offered");
        if out.report.converged {
            continue;
        }
        restored += out.report.kept_iteration.is_some() as usize;
        assert!(q >= best_q, "cap {cap}: returned q min {q:.4} below the best state met {best_q:.4}");
        assert!(out.report.to_string().contains("best state") == out.report.kept_iteration.is_some());
    }
    println!("{restored} capped runs finished from an earlier state");
}
