//! Each cloud's SSDF temperature from its spacing (docs/method.md, "ε1 follows the
//! spacing"), and the spacing a body's geoms share where one of them is a thin mesh.

use super::{Builder, Place};
use crate::contact::eps1_scale;
use crate::geometry::sample::Spacing;
use crate::geometry::shapes::Shape;
use crate::model::Pair;

impl Builder {
    /// Where a body has a thin mesh sampled finer than the scene's `spacing` (m) by default
    /// ([`Shape::spacing_within`]), its other colliding geoms sampled at that spacing, without
    /// one of their own, are sampled no coarser: the body's cloud then has one spacing, and the
    /// ε1 its planes are read with follows it ([`Builder::eps1_scales`]). One geom left at
    /// 1 cm (a fingertip's pad beside its thin link) would hold the body's planes at the
    /// default ε1 on a cloud sampled finer. Called only where the scene sets neither
    /// `scm_spacing` nor `scm_resolution` (then no mesh is sampled thin).
    pub(super) fn share_thin_spacings(
        &mut self,
        colliding: &[bool],
        spacing: f64,
        overrides: &[(String, f64, Place)],
    ) {
        let own = |g: &super::Geom| overrides.iter().any(|(n, _, _)| *n == g.name);
        let thin = |g: &super::Geom| match &g.shape {
            Some(Shape::Mesh(m)) if !own(g) => m.thin_spacing().filter(|t| *t < spacing),
            _ => None,
        };
        for b in 0..self.bodies.len() {
            let finest = (self.geoms.iter().zip(colliding))
                .filter(|(g, &c)| c && g.body == b)
                .filter_map(|(g, _)| thin(g).map(|t| (t, g.name.clone())))
                .reduce(|x, y| if y.0 < x.0 { y } else { x });
            let Some((finest, name)) = finest else {
                continue;
            };
            for (g, &c) in self.geoms.iter_mut().zip(colliding) {
                if !c || g.body != b || own(g) {
                    continue;
                }
                let (Some(shape), Some(s)) = (&g.shape, g.spacing.as_mut()) else {
                    continue;
                };
                // Only geoms at the scene's plain spacing: a large one, graded or sampled
                // coarser (a table, a long link), keeps its grid, whose points would grow as
                // `1/finest²` over its whole area (and the body's ε1 then stays the default).
                let longest = longest_quad(shape, s);
                if longest <= finest || longest > spacing {
                    continue;
                }
                *s = Spacing::uniform(finest);
                g.spacing_reason = format!("its body's thin mesh '{name}' at {finest} m, so that the body's planes are read with one ε1");
            }
        }
    }

    /// Gives each pair its clouds' ε1 factors ([`Pair::eps1_scale`]), each from the longest
    /// quad of its body's cloud (over the body's colliding geoms), unless the scene sets
    /// `scm_eps1`: every pair then reads the parameter as it is, the value the scene chose.
    pub(super) fn eps1_scales(&self, pairs: &mut [Pair], colliding: &[bool]) {
        if self.numeric.iter().any(|(n, _, _)| n == "scm_eps1") {
            return;
        }
        // Each body's longest quad, once (a scene may have tens of thousands of pairs).
        let mut longest: Vec<Option<f64>> = vec![None; self.bodies.len()];
        for (g, _) in self.geoms.iter().zip(colliding).filter(|(_, &c)| c) {
            if let (Some(shape), Some(spacing)) = (&g.shape, &g.spacing) {
                let l = longest_quad(shape, spacing);
                longest[g.body] = Some(longest[g.body].map_or(l, |x: f64| x.max(l)));
            }
        }
        // A plane's (no longest quad) is 1: its SSDF is the plane, whatever ε1.
        let scale = |b: usize| longest[b].map_or(1.0, eps1_scale);
        for p in pairs {
            p.eps1_scale = [scale(p.a), scale(p.b)];
        }
    }
}

/// The longest quad a geom is sampled with (m): a box's grid grows from `fine` at its edges to
/// `coarse` per axis away from them; every other shape is sampled evenly at the smallest
/// entry of `coarse` ([`Shape::sample_spaced`]).
pub(super) fn longest_quad(shape: &Shape, spacing: &Spacing) -> f64 {
    match shape {
        Shape::Box { .. } => spacing.coarse.max().max(spacing.fine),
        _ => spacing.coarse.min(),
    }
}
