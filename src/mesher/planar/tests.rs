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
