//! The warning a simulation gives when a smoothing length (`√ε1`, `ε2`, `ε3`) is as large as
//! a colliding body: the model then stays finite but is no longer contact.

use super::Simulation;
use crate::contact::Param;

impl Simulation {
    /// A warning when a smoothing length (`√ε1`, `ε2`, `ε3`) is as large as the smallest body
    /// in contact: the model is then no longer contact (ε1 smooths the SSDF over the whole
    /// body, ε2 averages the separation distribution instead of taking its minimum, ε3 pushes
    /// at any distance), though it stays finite. ε1 is compared body by body, as each body's
    /// planes are read with it (times the body's factor, [`crate::model::Pair::eps1_scale`]).
    /// `None` for other parameters or smaller values.
    pub(super) fn smoothing_warning(&self, p: Param, value: f64) -> Option<String> {
        let (length, what) = match p {
            Param::Eps1 => (value.sqrt(), "its square root smooths each SSDF over the whole body"),
            Param::Eps2 => (value, "the separation distribution becomes an average over the bodies instead of a soft minimum"),
            Param::Eps3 => (value, "the softplus pushes at any distance within the bodies' reach"),
            _ => return None,
        };
        // Each body's factor on the length: `√scale` for ε1, 1 for the others.
        let mut factor = vec![1.0; self.model.colliders.len()];
        if p == Param::Eps1 {
            for pair in &self.model.pairs {
                factor[pair.a] = pair.eps1_scale[0].sqrt();
                factor[pair.b] = pair.eps1_scale[1].sqrt();
            }
        }
        // The body whose smoothing comes nearest its size: (length over size, size, factor).
        let worst = (self.model.colliders.iter().zip(&factor))
            .filter_map(|(c, &f)| match c {
                Some(crate::collision::Collider::Aopc(s)) if !s.is_empty() => {
                    let d = s.bvh().diameter;
                    Some((length * f / d, d, f))
                }
                _ => None,
            })
            .fold(None, |w: Option<(f64, f64, f64)>, x| match w {
                Some(w) if w.0 >= x.0 => Some(w),
                _ => Some(x),
            })?;
        let (ratio, size, f) = worst;
        (ratio >= 1.0).then(|| {
            let (name, unit, _) = p.describe();
            let read = if f == 1.0 {
                String::new()
            } else {
                format!(" (read times {:.4} on that body's planes, which its spacing sets)", f * f)
            };
            format!("scm.{name} = {value:e} {unit}{read} is as large as a colliding body ({size:.3e} m across): {what}; the result is finite but no longer contact")
        })
    }
}
