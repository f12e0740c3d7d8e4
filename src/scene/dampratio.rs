//! An actuator's `dampratio`, turned into its `kv` as MuJoCo's compiler does it, on the inertia
//! the actuator drives at the reference configuration.

use super::mechanics::spatial_geometry;
use super::weights::{mass_at_q0, unit_velocity_kinematics};
use super::*;

impl Builder {
    /// Sets `kv` of every position actuator that gives `dampratio` ζ (and the damping of every
    /// `<general>` whose bias is a position servo's with a positive `biasprm[2]` = ζ) as
    /// MuJoCo's compiler does:
    /// `kv = 2 ζ √(kp m)` with `m = 1 / (gᵀ M⁻¹ g)` the inertia the actuator drives at `qpos0`,
    /// `g` its moment over the degrees of freedom (the gear on its joint, or the gear times a
    /// fixed tendon's coefficients). Compared with MuJoCo's compiled `actuator_biasprm`.
    pub(super) fn apply_dampratios(&mut self, tree: &Tree) -> Result<(), SceneError> {
        if self.dampratios.iter().all(Option::is_none) {
            return Ok(());
        }
        let inv = mass_at_q0(tree).1;
        for (a, z) in self.dampratios.iter().enumerate() {
            let Some((z, at)) = z else { continue };
            let actuator = &self.actuators[a];
            let moment: Vec<(usize, f64)> = match actuator.target {
                Transmission::Joint(j) => vec![(tree.joints[j].dadr, actuator.gear)],
                Transmission::Tendon(t) => self.tendons[t]
                    .joints
                    .iter()
                    .map(|&(j, c)| (tree.joints[j].dadr, actuator.gear * c))
                    .collect(),
                // The tendon's Jacobian at qpos0, ∂L/∂v, times the gear.
                Transmission::Spatial(t) => {
                    let (spec, segments) = &self.spatial_tendons[t];
                    let tendon = spatial_geometry(spec, segments);
                    unit_velocity_kinematics(tree, &tree.q0())
                        .iter()
                        .enumerate()
                        .map(|(k, kin)| (k, actuator.gear * tendon.length_and_rate(&kin.frames).1))
                        .collect()
                }
                // The slider-crank's moment at qpos0, the same way.
                Transmission::SliderCrank(k) => {
                    let crank = &self.transmissions.slider_cranks[k];
                    let moves = |b: usize| tree.body_moves(b) && !tree.bodies[b].mocap;
                    let moves = (moves(crank.crank.1), moves(crank.slider.1));
                    unit_velocity_kinematics(tree, &tree.q0())
                        .iter()
                        .enumerate()
                        .map(|(d, kin)| {
                            (
                                d,
                                actuator.gear * crank.length_and_rate(&kin.frames, moves).1,
                            )
                        })
                        .collect()
                }
                // No moment without contacts (an adhesion has no damping ratio to read).
                Transmission::Body(_) => Vec::new(),
                // The site's moment at qpos0: its velocity for a unit velocity of each dof.
                Transmission::Site(k) => {
                    let site = &self.transmissions.sites[k];
                    let moves = tree.body_moves(site.body) && !tree.bodies[site.body].mocap;
                    unit_velocity_kinematics(tree, &tree.q0())
                        .iter()
                        .enumerate()
                        .map(|(d, kin)| (d, site.velocity(&kin.frames[site.body], moves)))
                        .collect()
                }
            };
            let w: f64 = match &inv {
                Some(inv) => moment
                    .iter()
                    .flat_map(|&(i, gi)| moment.iter().map(move |&(k, gk)| gi * gk * inv[(i, k)]))
                    .sum(),
                None => f64::NAN,
            };
            let kp = match &self.actuators[a].kind {
                ActuatorKind::Position { kp, .. } => *kp,
                ActuatorKind::General { gain, .. } => gain[0],
                _ => 0.0,
            };
            // MuJoCo's compiler gives no damping where the moment's inverse weight is below
            // 1e-15 (its mjMINVAL): the actuator moves nothing at qpos0 (measured with MuJoCo
            // 4.0.0, kv = 0 at 3.1e-16, the full value at 2.8e-15).
            if w.is_finite() && (0.0..1e-15).contains(&w) && kp >= 0.0 {
                let warning = format!(
                    "{}:{}: <actuator> '{}': dampratio gives kv = 0, as in MuJoCo: the actuator's moment vanishes at qpos0 (inverse weight {w:.1e}), so it drives no inertia there",
                    at.file, at.line, actuator.name
                );
                self.warnings.push(warning);
                match &mut self.actuators[a].kind {
                    ActuatorKind::Position { kv, .. } => *kv = 0.0,
                    ActuatorKind::General { bias, .. } => bias[2] = 0.0,
                    _ => {}
                }
                continue;
            }
            if w.is_nan() || w <= 0.0 || kp < 0.0 {
                return Err(SceneError {
                    file: at.file.to_string(),
                    line: at.line,
                    element: "actuator".into(),
                    message: if kp < 0.0 {
                        format!("actuator '{}': a damping ratio needs a gain that is not negative (here {kp}): give kv instead", actuator.name)
                    } else {
                        format!("actuator '{}': a damping ratio needs the inertia it drives, and the mass matrix at qpos0 gives none (a massless chain, or a zero gear): give kv instead", actuator.name)
                    },
                });
            }
            match &mut self.actuators[a].kind {
                ActuatorKind::Position { kp, kv } => *kv = 2.0 * *z * (*kp / w).sqrt(),
                ActuatorKind::General { gain, bias } => bias[2] = -2.0 * *z * (gain[0] / w).sqrt(),
                _ => {}
            }
        }
        Ok(())
    }
}
