//! The sphere of `sphere_drop.xml` falls, bounces and comes to rest on the plane at the
//! equilibrium penetration.

use crate::common::{bisect, scene, static_lift};
use scm::collision::Collider;
use scm::fmi::contract::FmiModel;
use scm::scalar::softplus;
use scm::sim::Simulation;

#[test]
fn sphere_comes_to_rest_at_the_equilibrium_penetration() {
    let mut sim = Simulation::from_file(&scene("sphere_drop")).unwrap();
    let (h, mut t) = (0.01, 0.0);
    for _ in 0..300 {
        sim.do_step(t, h).unwrap();
        t += h;
    }
    let (z, vz) = (sim.data.current.state.q[2], sim.data.current.state.v[2]);
    assert!(vz.abs() < 1e-6, "still moving after 3 s: vz = {vz}");
    let prm = sim.data.current.params;
    let (m, g, r) = (1.0, 9.81, 0.05);

    // 1. The static balance of the SCM over this very AOPC, written out independently of the
    //    dynamics code: at rest (v = 0, so d = 1 and no friction) the separation-weighted
    //    normal force Σ W_f k s⁺(-Φ_f), Φ_f = z + p_f.z, carries the weight.
    let Some(Collider::Aopc(aopc)) = &sim.model.colliders[1] else {
        panic!("the ball has an AOPC")
    };
    let lift = |z: f64| static_lift(aopc, &prm, z);
    let z_balance = bisect(|z| m * g - lift(z), 0.0, r);
    println!("resting centre height {z:.9} m, static balance {z_balance:.9} m");
    assert!(
        (z - z_balance).abs() < 1e-7,
        "rest {z} vs static balance {z_balance}"
    );

    // 2. The analytic point contact m g = k s⁺_ε3(-φ): the sphere rests on the four AOPC
    //    points around its pole, which share the load equally (the SCM force is a weighted
    //    average, so four points at φ give the force of one). The next ring of points is
    //    1.9 mm higher, ≈ 9.5 ε2 (weight 8 e^-9.5 ≈ 6e-4 of the total): 1 % covers it.
    let phi = bisect(
        |phi| m * g - prm.stiffness * softplus(-phi, prm.eps3),
        -r,
        r,
    );
    let lowest = z + aopc
        .points
        .iter()
        .map(|p| p.z)
        .fold(f64::INFINITY, f64::min);
    println!("lowest points at {lowest:.6e} m, analytic point contact {phi:.6e} m");
    assert!(
        lowest < 0.0 && (lowest - phi).abs() < 0.01 * phi.abs(),
        "penetration {lowest} vs analytic {phi}"
    );
}
