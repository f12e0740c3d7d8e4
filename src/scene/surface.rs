//! Moving surfaces (MuJoCo's geom `surfacevel`; docs/method.md, departure 8): a static body's
//! planes and moving geoms on bodies of their own, each body's surface flow, and the pairs'.

use super::*;
use crate::model::Pair;

impl Builder {
    /// A static body (welded to the world) may hold planes beside other geoms, as MuJoCo's
    /// worldbody usually does (floor and fixed obstacles), and geoms whose surface moves
    /// (`surfacevel`: a treadmill's belt and rollers beside its frame); SCM's collider is one
    /// shape per body with one surface flow, so each such geom moves to a static body of its
    /// own, named after the geom (made unique), in the same frame. Nothing moves: the bodies
    /// are welded to the world.
    pub(super) fn split_static_geoms(&mut self) {
        let weld = filter::weld_bodies(&self.bodies);
        // New bodies are pushed below; only the bodies that existed before are visited.
        for (b, &w) in weld.iter().enumerate() {
            if w != 0 {
                continue;
            }
            let on_b: Vec<usize> = (0..self.geoms.len())
                .filter(|&g| self.geoms[g].body == b)
                .collect();
            let planes: Vec<usize> = on_b
                .iter()
                .copied()
                .filter(|&g| self.geoms[g].shape.is_none() || self.geoms[g].surfacevel.is_some())
                .collect();
            if planes.is_empty() || (planes.len() == 1 && on_b.len() == 1) {
                continue;
            }
            for g in planes {
                let mut name = self.geoms[g].name.clone();
                while self.bodies.iter().any(|x| x.name == name) {
                    name.push('_');
                }
                let index = self.bodies.len();
                self.bodies.push(Body {
                    name,
                    parent: Some(b),
                    offset: Isometry3::identity(),
                    inertia: NO_INERTIA,
                    joints: vec![],
                    mocap: false,
                    gravcomp: 0.0,
                });
                self.explicit_inertia.push(false);
                self.geom_inertia.push(NO_INERTIA);
                self.geoms[g].body = index;
            }
        }
    }

    /// The flow of body `b`'s moving surface in its frame (MuJoCo's geom `surfacevel`,
    /// `v + ω × (x - p)` in a geom's frame about its origin `p`; docs/method.md, departure 8),
    /// from its colliding geoms; `None` where none moves. SCM's contact acts between whole
    /// bodies, so the colliding geoms of a body whose surface moves must all move alike (a
    /// static body's moving geoms have bodies of their own, [`Builder::split_static_geoms`]).
    pub(super) fn surface_flow(
        &self,
        b: usize,
        colliding: &[bool],
    ) -> Result<Option<Twist<f64>>, SceneError> {
        let members: Vec<&Geom> = (0..self.geoms.len())
            .filter(|&g| colliding[g] && self.geoms[g].body == b)
            .map(|g| &self.geoms[g])
            .collect();
        let flow = |g: &Geom| {
            g.surfacevel.map(|(v, w)| {
                let (r, p) = (g.pose.rotation, g.pose.translation.vector);
                let ang = r * w;
                Twist {
                    lin: r * v - ang.cross(&p),
                    ang,
                }
            })
        };
        let Some(first) = members.iter().find_map(|g| flow(g)) else {
            return Ok(None);
        };
        let scale = first.lin.norm() + first.ang.norm();
        for g in &members {
            let same = flow(g).is_some_and(|f| {
                (f.lin - first.lin).norm() + (f.ang - first.ang).norm() <= 1e-12 * scale
            });
            if !same {
                return Err(SceneError {
                    file: g.file.clone(),
                    line: g.line,
                    element: "geom".into(),
                    message: format!(
                        "geom '{}' of moving body '{}': the body's colliding geoms have different surfacevel; SCM's contact acts between whole bodies with one surface flow each: give the moving geoms a body of their own, welded to this one (a child <body> without joints)",
                        g.name, self.bodies[b].name
                    ),
                });
            }
        }
        Ok(Some(first))
    }

    /// `pairs` with their bodies' surface flows ([`Pair::surface`]): where either body's surface
    /// moves, both bodies' flows (a still one zero); `colliding` the geoms that collide.
    pub(super) fn with_surfaces(
        &self,
        pairs: Vec<Pair>,
        colliding: &[bool],
    ) -> Result<Vec<Pair>, SceneError> {
        let flows = (0..self.bodies.len())
            .map(|b| self.surface_flow(b, colliding))
            .collect::<Result<Vec<_>, _>>()?;
        let still = Twist {
            lin: Vector3::zeros(),
            ang: Vector3::zeros(),
        };
        Ok(pairs
            .into_iter()
            .map(|p| Pair {
                surface: (flows[p.a].is_some() || flows[p.b].is_some())
                    .then(|| [flows[p.a].unwrap_or(still), flows[p.b].unwrap_or(still)]),
                ..p
            })
            .collect())
    }
}
