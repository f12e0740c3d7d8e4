//! Which bodies collide, by MuJoCo's rules:
//!
//! - two geoms may touch when `contype` of one shares a bit with `conaffinity` of the other;
//!   a geom with both zero (the usual visual geom) touches nothing and is left out of its
//!   body's collider;
//! - bodies are grouped into *weld bodies*: a body without joints moves with its parent, so it
//!   belongs to its parent's weld body (the world's, for static bodies). Geoms of one weld body
//!   never touch each other;
//! - the parent filter (on unless `<flag filterparent="disable">`): a weld body does not touch
//!   its parent weld body, except the world;
//! - `<contact><exclude body1 body2>` removes a body pair; `<contact><pair geom1 geom2>` adds
//!   one whatever the rules say, through its two geoms only (a visual geom of either body does
//!   not join the collider by it).
//!
//! SCM's contact acts between whole bodies (each body's collider is the union of its colliding
//! geoms). Where the bits let a geom touch some bodies and not others, the pair is still
//! evaluated body against body, and the loader says so in a warning.

use super::Geom;
use crate::dynamics::Body;

/// Bits of two geoms allow contact.
pub fn compatible(a: &Geom, b: &Geom) -> bool {
    (a.contype & b.conaffinity) != 0 || (b.contype & a.conaffinity) != 0
}

/// The weld body of every body: itself if it has joints or is a mocap body, else its
/// parent's (the world is 0).
pub fn weld_bodies(bodies: &[Body]) -> Vec<usize> {
    let mut weld = vec![0; bodies.len()];
    for (b, body) in bodies.iter().enumerate().skip(1) {
        weld[b] = if !body.joints.is_empty() || body.mocap {
            b
        } else {
            weld[body.parent.unwrap_or(0)]
        };
    }
    weld
}

/// The rules of the module doc, as settings.
pub struct Rules<'a> {
    /// Bodies of the model.
    pub bodies: &'a [Body],
    /// Geoms of the model.
    pub geoms: &'a [Geom],
    /// Whether the parent filter is on.
    pub filterparent: bool,
    /// Excluded body pairs `(a, b)` with `a < b`.
    pub excluded: &'a [(usize, usize)],
    /// Explicit body pairs `(a, b)` with `a < b`.
    pub explicit: &'a [(usize, usize)],
    /// The geoms (indices) of each explicit pair, in the pairs' order.
    pub explicit_geoms: &'a [(usize, usize)],
}

impl Rules<'_> {
    /// Whether bodies `a` and `b` are kept apart by weld bodies and the parent filter.
    pub fn filtered(&self, weld: &[usize], a: usize, b: usize) -> bool {
        let (wa, wb) = (weld[a], weld[b]);
        if wa == wb {
            return true;
        }
        let parent = |w: usize| weld[self.bodies[w].parent.unwrap_or(0)];
        self.filterparent && wa != 0 && wb != 0 && (wa == parent(wb) || wb == parent(wa))
    }

    /// Whether bodies `a < b` form a colliding pair.
    pub fn pair(&self, weld: &[usize], a: usize, b: usize) -> bool {
        if self.explicit.contains(&(a, b)) {
            return true;
        }
        if self.filtered(weld, a, b) || self.excluded.contains(&(a, b)) {
            return false;
        }
        let of = |body: usize| self.geoms.iter().filter(move |g| g.body == body);
        of(a).any(|ga| of(b).any(|gb| compatible(ga, gb)))
    }

    /// For each geom, whether it can touch anything: a compatible geom of a body it pairs with
    /// (past the weld and parent filters), or its place in an explicit pair. Only the geoms an
    /// explicit pair names join their bodies' colliders through it, as MuJoCo collides only
    /// them: Adroit's finger links pair their capsules explicitly, and their visual meshes
    /// (`contype` and `conaffinity` 0) once joined the colliders too, their far side pushing
    /// the nail board with 138 N from 6.8 cm away.
    pub fn colliding_geoms(&self, weld: &[usize], pairs: &[(usize, usize)]) -> Vec<bool> {
        self.geoms
            .iter()
            .enumerate()
            .map(|(i, g)| {
                let named = |&(x, y): &(usize, usize)| x == i || y == i;
                pairs.iter().any(|&(a, b)| {
                    let other = if g.body == a {
                        b
                    } else if g.body == b {
                        a
                    } else {
                        return false;
                    };
                    let key = (a.min(b), a.max(b));
                    self.explicit
                        .iter()
                        .zip(self.explicit_geoms)
                        .any(|(k, geoms)| *k == key && named(geoms))
                        || (!self.filtered(weld, a, b)
                            && self
                                .geoms
                                .iter()
                                .any(|h| h.body == other && compatible(g, h)))
                })
            })
            .collect()
    }
}
