//! The contact outputs, computed when first read at a state and only as far as they are read:
//! each pair's wrenches as the dynamics apply them (the pairs proven out of reach cost their
//! proof and push with zero), and the smooth distances, which need every pair in full, only
//! once a distance is read (see docs/fmu.md, "What an output read costs").

use super::{SimState, Simulation};
use crate::contact::PairContact;

/// The contact outputs at the state they were last read at (a memo in
/// [`Data`](super::Data)).
///
/// Evaluated afresh at each state: keeping the pairs' candidate planes from one row to the
/// next, as the integrator does, saved nothing measurable on gymnasium's humanoid with rows
/// every 0.01 s and raised the run's peak memory from 16 MB to 320 MB (every pair's
/// candidates, where the integrator keeps those of the pairs in reach only).
#[derive(Clone, Debug, Default)]
pub(super) struct ContactOutputs {
    /// The state the results were computed at: they serve while the current state is this
    /// one (`None`: none computed yet).
    at: Option<SimState>,
    /// Every pair's contact as the dynamics apply it ([`Model::contact_forces`]): `None` for a
    /// pair proven out of reach (zero wrenches, its distance not evaluated).
    ///
    /// [`Model::contact_forces`]: crate::model::Model::contact_forces
    applied: Vec<Option<PairContact<f64>>>,
    /// Every pair's contact with its smooth distance: `applied`, and for the pairs it leaves
    /// out zero wrenches with the distance of a full evaluation. Filled when a distance or
    /// [`Simulation::contacts`] is first read at this state.
    complete: Option<Vec<PairContact<f64>>>,
}

impl Simulation {
    /// Every pair's contact at the current state: the wrenches the dynamics apply (zero for a
    /// pair proven out of reach, whose forces are all below τ k ε3), and the smooth distance
    /// `D` of every pair (evaluated in full for those out of reach). What the FMU's
    /// `contact.A.B.*` outputs read.
    pub fn contacts(&mut self) -> &[PairContact<f64>] {
        self.applied_contacts();
        let memo = &mut self.data.outputs;
        if memo.complete.is_none() {
            let at = memo
                .at
                .as_ref()
                .expect("the applied contacts were just computed");
            let kin = self
                .model
                .tree
                .kinematics_with(&at.state.q, &at.state.v, &at.mocap);
            let pulls = self.model.pulls(&at.driven(&self.model));
            memo.complete =
                Some(
                    self.model
                        .complete_contacts(&kin, &at.params, &pulls, &memo.applied),
                );
        }
        memo.complete.as_deref().unwrap_or(&[])
    }

    /// Every pair's contact as the dynamics apply it at the current state (`None`: proven out
    /// of reach, no force): the proofs and the pairs in reach only, no distance evaluated
    /// beyond them. What the force and torque outputs read.
    pub(super) fn applied_contacts(&mut self) -> &[Option<PairContact<f64>>] {
        let memo = &mut self.data.outputs;
        if memo.at.as_ref() != Some(&self.data.current) {
            let at = &self.data.current;
            let kin = self
                .model
                .tree
                .kinematics_with(&at.state.q, &at.state.v, &at.mocap);
            let pulls = self.model.pulls(&at.driven(&self.model));
            memo.applied = self.model.contact_forces(&kin, &at.params, &pulls).1;
            memo.complete = None;
            memo.at = Some(at.clone());
        }
        &memo.applied
    }

    /// Whether the smooth distances of the current state have been evaluated (for the tests
    /// of what a read costs).
    #[cfg(test)]
    pub(super) fn distances_evaluated(&self) -> bool {
        let m = &self.data.outputs;
        m.at.as_ref() == Some(&self.data.current) && m.complete.is_some()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A box and a ball resting on a floor, 1.5 cm apart: two pairs in contact, one out of
    /// reach (its force, about 1e-55 N, is not zero: only the proof makes it so).
    fn resting() -> Simulation {
        let text = r#"<mujoco model="outputs"><option timestep="0.002"/>
  <custom><numeric name="scm_spacing" data="0.02"/></custom>
  <worldbody><geom name="floor" type="plane" size="1 1 0.1"/>
    <body name="box" pos="0 0 0.049"><freejoint/><geom type="box" size="0.05 0.05 0.05" mass="1"/></body>
    <body name="ball" pos="0.115 0 0.049"><freejoint/><geom type="sphere" size="0.05" mass="1"/></body>
  </worldbody></mujoco>"#;
        let scene = crate::scene::load_str(text, std::path::Path::new("outputs.xml")).unwrap();
        Simulation::new(scene, text)
    }

    /// Every pair evaluated in full at the current state, afresh (what the outputs were before
    /// they were read lazily).
    fn full(sim: &Simulation) -> Vec<PairContact<f64>> {
        let at = &sim.data.current;
        let kin = sim
            .model
            .tree
            .kinematics_with(&at.state.q, &at.state.v, &at.mocap);
        sim.model.contacts(&kin, &at.params, &[]).1
    }

    #[test]
    fn forces_read_are_the_applied_ones_and_distances_those_of_a_full_evaluation() {
        let mut sim = resting();
        let pairs: Vec<String> = sim
            .model
            .pairs
            .iter()
            .map(|p| {
                let name = |b: usize| sim.model.tree.bodies[b].name.clone();
                format!("contact.{}.{}", name(p.a), name(p.b))
            })
            .collect();
        assert_eq!(pairs.len(), 3, "{pairs:?}");
        let far = pairs.iter().position(|n| n == "contact.box.ball").unwrap();
        for row in 0..20 {
            if row > 0 {
                sim.advance(0.01).unwrap();
            }
            let reference = full(&sim);
            // Forces first: the far pair pushes with exactly zero, as in the dynamics (its
            // full evaluation's force is below τ k ε3, not zero), the pairs in contact with
            // their full evaluation's force, to the bit; no distance is evaluated for them.
            for (k, name) in pairs.iter().enumerate() {
                for (axis, i) in [("x", 0), ("y", 1), ("z", 2)] {
                    let f = sim.get(&format!("{name}.force.{axis}")).unwrap();
                    let m = sim.get(&format!("{name}.torque.{axis}")).unwrap();
                    let (want_f, want_m) = if k == far {
                        (0.0, 0.0)
                    } else {
                        (reference[k].on_a.force[i], reference[k].on_a.torque[i])
                    };
                    assert_eq!(
                        f.to_bits(),
                        want_f.to_bits(),
                        "row {row}: {name}.force.{axis}"
                    );
                    assert_eq!(
                        m.to_bits(),
                        want_m.to_bits(),
                        "row {row}: {name}.torque.{axis}"
                    );
                }
            }
            assert!(
                reference[far].on_a.force.norm() > 0.0,
                "row {row}: the far pair's full evaluation pushes, if only just"
            );
            assert!(
                reference[far].on_a.force.norm()
                    < 1e-15 * sim.data.current.params.stiffness * sim.data.current.params.eps3,
                "row {row}: the far pair's force {:e}",
                reference[far].on_a.force.norm()
            );
            assert!(!sim.distances_evaluated(), "row {row}: forces read only");
            // Distances: every pair's, the far one's included, as a fresh full evaluation
            // gives it, to the bit.
            for (k, name) in pairs.iter().enumerate() {
                let d = sim.get(&format!("{name}.distance")).unwrap();
                assert_eq!(
                    d.to_bits(),
                    reference[k].distance.to_bits(),
                    "row {row}: {name}"
                );
            }
            assert!(sim.distances_evaluated());
            let d_far = reference[far].distance;
            assert!((0.01..0.02).contains(&d_far), "row {row}: {d_far}");
        }
        // Their exact derivatives agree: the far pair's force and torque do not move with the
        // ball (they are zero wherever the proof holds); its distance does, as its central
        // difference says (`D` is smooth; 1e-6 m steps, rounding about 1e-10 m / 1e-6 m).
        let far_name = &pairs[far];
        let vr = |sim: &Simulation, name: &str| sim.variable(name).unwrap().0.value_reference;
        let known = vr(&sim, "ball.pos.x");
        let unknowns: Vec<u32> = ["force.x", "force.z", "torque.y", "distance"]
            .iter()
            .map(|what| vr(&sim, &format!("{far_name}.{what}")))
            .collect();
        let exact = crate::fmi::contract::FmiModel::directional_derivative(
            &mut sim,
            &unknowns,
            &[known],
            &[1.0],
        )
        .unwrap();
        assert_eq!(exact[..3], [0.0; 3], "{exact:?}");
        let x = sim.get("ball.pos.x").unwrap();
        let mut distance_at = |dx: f64| {
            sim.data.current.state.q[7] = x + dx;
            sim.get(&format!("{far_name}.distance")).unwrap()
        };
        let central = (distance_at(1e-6) - distance_at(-1e-6)) / 2e-6;
        sim.data.current.state.q[7] = x;
        assert!(central > 0.5, "the ball moves away from the box: {central}");
        assert!(
            (exact[3] - central).abs() < 1e-6,
            "{} against {central}",
            exact[3]
        );
        let d_box = sim.contacts()[pairs.iter().position(|n| n == "contact.world.box").unwrap()];
        assert!(
            d_box.on_a.force.z < -5.0,
            "the floor carries the box: {d_box:?}"
        );
    }

    #[test]
    fn reading_the_outputs_changes_no_step() {
        let run = |read: bool| {
            let mut sim = resting();
            sim.set("ball.linvel.x", super::super::Value::Real(-0.5))
                .unwrap();
            for _ in 0..30 {
                sim.advance(0.01).unwrap();
                if read {
                    sim.outputs().unwrap();
                }
            }
            sim.data.current.state.clone()
        };
        let (read, unread) = (run(true), run(false));
        assert_eq!(read, unread);
        // At rest the box stays within 1e-6 m of x = 0; struck, it moves 0.4 mm.
        assert!(
            read.q[0] < -1e-4,
            "the ball struck the box: x = {}",
            read.q[0]
        );
    }
}
