//! Colliders and colliding pairs: one collider per body, MuJoCo's filters, the pairs'
//! friction, and the `<contact>` section (`exclude`, `pair`).

use super::*;

/// What made a body's cloud: its colliding geoms' shapes and poses in the body, their
/// spacings, and the body ([`Builder::collider`]).
pub(super) type Sampled = (
    Vec<(Shape, Isometry3<f64>)>,
    Vec<Spacing>,
    usize,
    Vec<usize>,
);

impl Builder {
    /// A body's collider from its geoms that can touch something: the exact half-space of a
    /// plane, or the AOPC of the union of the other geoms, each at its own spacing
    /// ([`Geom::spacing`], set by [`Builder::assign_spacings`]).
    ///
    /// `sampled` holds what made each cloud so far (the geoms' shapes, poses in the body and
    /// spacings) with the body of `made` (the colliders so far) that has it: the copies of one
    /// body (a replicate's, an attach's) are sampled once, to the same bits. Sets each sampled
    /// geom's [`Geom::points`].
    pub(super) fn collider(
        &mut self,
        b: usize,
        colliding: &[bool],
        sampled: &mut Vec<Sampled>,
        made: &[Option<Collider>],
    ) -> Result<Option<Collider>, SceneError> {
        let members: Vec<usize> = (0..self.geoms.len())
            .filter(|&g| colliding[g] && self.geoms[g].body == b)
            .collect();
        let geoms: Vec<&Geom> = members.iter().map(|&g| &self.geoms[g]).collect();
        if let Some(p) = geoms.iter().find(|g| g.shape.is_none()) {
            if geoms.len() > 1 {
                return Err(SceneError {
                    file: p.file.clone(),
                    line: p.line,
                    element: "geom".into(),
                    message: format!("plane '{}' shares moving body '{}' with other geoms: a plane belongs to a static body", p.name, self.bodies[b].name),
                });
            }
            return Ok(Some(Collider::HalfSpace {
                point: p.pose.translation.vector,
                normal: p.pose.rotation * Vector3::z(),
            }));
        }
        if geoms.is_empty() {
            return Ok(None);
        }
        let parts: Vec<(Shape, Isometry3<f64>)> = geoms
            .iter()
            .map(|g| (g.shape.clone().expect("planes handled above"), g.pose))
            .collect();
        let spacings: Vec<Spacing> = geoms
            .iter()
            .map(|g| g.spacing.expect("a colliding geom has its spacing"))
            .collect();
        // A box of a union is cut again where the other boxes cross it (more windows, each
        // graded from both ends): counted on its own grid lines.
        let estimate: f64 = parts
            .iter()
            .zip(&spacings)
            .enumerate()
            .map(|(k, ((shape, _), h))| match shape {
                Shape::Box { .. } if parts.len() > 1 => {
                    crate::geometry::union::box_quads_in_union(&parts, &spacings, k)
                }
                _ => estimated_points(shape, h),
            })
            .sum();
        if estimate.is_nan() || estimate > MAX_AOPC_POINTS {
            let listed = geoms
                .iter()
                .zip(&spacings)
                .map(|(g, h)| format!("'{}' at {}", g.name, spacing_text(h)))
                .collect::<Vec<_>>()
                .join(", ");
            return Err(SceneError {
                file: geoms[0].file.clone(),
                line: geoms[0].line,
                element: "geom".into(),
                message: format!("body '{}' (geoms {listed}) would get about {estimate:.3e} AOPC points (at most {MAX_AOPC_POINTS:e}): increase scm_spacing, sample large geoms coarsely away from their edges with scm_resolution (16 quads per radius or half-extent: <numeric name=\"scm_resolution\" data=\"16\"/>), give a geom its own spacing with scm_spacing:NAME, or make the geoms smaller", self.bodies[b].name),
            });
        }
        // Compared exactly (a linear search: the distinct bodies of a scene are few).
        let copy = sampled
            .iter()
            .find(|(p, h, _, _)| *p == parts && *h == spacings)
            .and_then(|(_, _, first, counts)| match &made[*first] {
                Some(Collider::Aopc(same)) => Some((same.clone(), counts.clone())),
                _ => None,
            });
        let (aopc, counts) = copy.unwrap_or_else(|| {
            let (aopc, counts) = crate::geometry::union::sample_union_counted(&parts, &spacings);
            sampled.push((parts, spacings, b, counts.clone()));
            (aopc, counts)
        });
        for (&g, &n) in members.iter().zip(&counts) {
            self.geoms[g].points = Some(n);
        }
        Ok(Some(Collider::Aopc(aopc)))
    }

    /// Sets every colliding geom's spacing and why (docs/geometry.md, "Spacing per geom"): its
    /// own `scm_spacing:NAME` when the scene gives one; else [`Shape::spacing_for`] the scene's
    /// `spacing` and `resolution`, with [`AUTO_RESOLUTION`] when the scene sets neither
    /// `scm_spacing` nor `scm_resolution` (`resolution` is `None`). A per-geom setting that
    /// names no geom, or a plane (exact, not sampled), is an error; one for a geom that
    /// collides with nothing is a warning (unused).
    pub(super) fn assign_spacings(
        &mut self,
        spacing: f64,
        resolution: Option<f64>,
        overrides: &[(String, f64, Place)],
        colliding: &[bool],
    ) -> Result<(), SceneError> {
        // A setting given twice is a <numeric> name given twice: refused with the names.
        for (name, _, at) in overrides {
            let setting = format!("{GEOM_SPACING_PREFIX}{name}");
            let Some(g) = self.geoms.iter().position(|g| g.name == *name) else {
                return Err(self.setting_error(
                    at,
                    &setting,
                    format!("no geom is named '{name}' (the name after '{GEOM_SPACING_PREFIX}' is a geom's name attribute)"),
                ));
            };
            if self.geoms[g].shape.is_none() {
                return Err(self.setting_error(
                    at,
                    &setting,
                    format!("geom '{name}' is a plane, an exact half-space that is not sampled: remove the setting"),
                ));
            }
            if !colliding[g] {
                self.warnings.push(format!(
                    "{at}: {setting}: geom '{name}' collides with nothing, so its spacing is unused"
                ));
            }
        }
        for (g, geom) in self.geoms.iter_mut().enumerate() {
            let (spacing, reason) = match (&geom.shape, colliding[g]) {
                (Some(shape), true) => {
                    let own = overrides.iter().rev().find(|(n, _, _)| *n == geom.name);
                    match (own, resolution) {
                        (Some((_, v, _)), _) => (
                            Some(Spacing::uniform(*v)),
                            format!("its own: {GEOM_SPACING_PREFIX}{}", geom.name),
                        ),
                        // An infinite resolution (`scm_spacing` alone) samples evenly.
                        (None, Some(n)) => (
                            Some(shape.spacing_for(spacing, n)),
                            match n.is_finite() {
                                true => format!("the scene's spacing, graded up to its size / {n} by scm_resolution"),
                                false => "the scene's scm_spacing".into(),
                            },
                        ),
                        (None, None) => (
                            Some(shape.spacing_within(spacing, AUTO_RESOLUTION, AUTO_SAGITTA)),
                            auto_reason(shape, spacing),
                        ),
                    }
                }
                _ => (None, String::new()),
            };
            geom.spacing = spacing;
            geom.spacing_reason = reason;
        }
        if resolution.is_none() {
            self.share_thin_spacings(colliding, spacing, overrides);
        }
        Ok(())
    }

    /// Colliding body pairs by MuJoCo's rules ([`filter`]), and which geoms collide at all.
    pub(super) fn pairs(&mut self) -> Result<(Vec<Pair>, Vec<bool>), SceneError> {
        let body_of = |name: &str, line: usize, what: &str| -> Result<usize, SceneError> {
            self.bodies
                .iter()
                .position(|b| b.name == name)
                .ok_or_else(|| SceneError {
                    file: self.file.clone(),
                    line,
                    element: what.into(),
                    message: format!("no body named '{name}'"),
                })
        };
        let mut excluded = Vec::new();
        for (b1, b2, line) in &self.excludes {
            let (x, y) = (
                body_of(b1, *line, "exclude")?,
                body_of(b2, *line, "exclude")?,
            );
            excluded.push((x.min(y), x.max(y)));
        }
        let mut explicit = Vec::new();
        let mut explicit_geoms = Vec::new();
        let mut explicit_friction = Vec::new();
        let mut explicit_margin = Vec::new();
        for ExplicitPair {
            geoms: [g1, g2],
            friction,
            condim,
            margin,
            adhesion,
            gap,
            line,
            ..
        } in &self.explicit_pairs
        {
            let find = |g: &str| {
                self.geoms
                    .iter()
                    .position(|x| x.name == g)
                    .ok_or_else(|| SceneError {
                        file: self.file.clone(),
                        line: *line,
                        element: "pair".into(),
                        message: format!("no geom named '{g}'"),
                    })
            };
            let (i, j) = (find(g1)?, find(g2)?);
            let (x, y) = (self.geoms[i].body, self.geoms[j].body);
            if x == y {
                return Err(SceneError {
                    file: self.file.clone(),
                    line: *line,
                    element: "pair".into(),
                    message: "both geoms belong to the same body".into(),
                });
            }
            explicit.push((x.min(y), x.max(y)));
            explicit_geoms.push((i, j));
            // Under `override` a pair takes `o_friction` unless its own condim makes it
            // frictionless (MuJoCo reads the pair's condim, not its geoms').
            let friction = match self.flags.override_contacts {
                true if *condim == 1 => Some(0.0),
                true => Some(self.contact_override.friction),
                false => *friction,
            };
            explicit_friction.push(((x.min(y), x.max(y)), friction));
            explicit_margin.push(((x.min(y), x.max(y)), *margin, (*adhesion, *gap)));
        }
        let rules = filter::Rules {
            bodies: &self.bodies,
            geoms: &self.geoms,
            filterparent: self.flags.filterparent,
            excluded: &excluded,
            explicit: &explicit,
            explicit_geoms: &explicit_geoms,
        };
        let weld = filter::weld_bodies(&self.bodies);
        // MuJoCo skips pairs where neither weld body has degrees of freedom (static or mocap).
        let moves = |b: usize| weld[b] != 0 && !self.bodies[weld[b]].joints.is_empty();
        let nb = self.bodies.len();
        let mut body_pairs = Vec::new();
        for a in 0..nb {
            for b in a + 1..nb {
                if (moves(a) || moves(b)) && rules.pair(&weld, a, b) {
                    body_pairs.push((a, b));
                }
            }
        }
        let colliding = rules.colliding_geoms(&weld, &body_pairs);
        // Say where whole-body contact reaches further than the bits.
        let mut notes = Vec::new();
        for &(a, b) in &body_pairs {
            if explicit.contains(&(a, b)) {
                continue;
            }
            for (g, _) in self
                .geoms
                .iter()
                .zip(&colliding)
                .filter(|(g, &c)| c && (g.body == a || g.body == b))
            {
                let other = if g.body == a { b } else { a };
                let any = self
                    .geoms
                    .iter()
                    .zip(&colliding)
                    .any(|(h, &c)| c && h.body == other && filter::compatible(g, h));
                if !any {
                    notes.push(format!(
                        "{}:{}: geom '{}' of body '{}' touches body '{}' in SCM although its contype/conaffinity exclude every geom of it (SCM's contact acts between whole bodies)",
                        g.file, g.line, g.name, self.bodies[g.body].name, self.bodies[other].name
                    ));
                }
            }
        }
        self.warnings.extend(notes);
        let pairs = body_pairs
            .into_iter()
            .map(|(a, b)| {
                let own = explicit_friction
                    .iter()
                    .find(|(k, _)| *k == (a, b))
                    .and_then(|(_, f)| *f);
                let friction = own.or_else(|| self.geom_friction(a, b, &colliding));
                let explicit = explicit_margin.iter().find(|(k, _, _)| *k == (a, b));
                let margin = match explicit {
                    _ if self.flags.override_contacts => self.contact_override.margin,
                    Some((_, m, _)) => *m,
                    None => self.geom_margin(a, b, &colliding),
                };
                let (adhesion, gap) = match explicit {
                    Some((_, _, own)) => *own,
                    None => self.geom_adhesion(a, b, &colliding),
                };
                Pair {
                    a,
                    b,
                    friction,
                    stiffness: None,
                    rest: None,
                    dissipation_velocity: None,
                    dissipation_force: None,
                    hold_separation: false,
                    margin,
                    adhesion,
                    gap,
                    stiction_floor: 0.0,
                    surface: None,
                    eps1_scale: [1.0; 2],
                }
            })
            .collect();
        Ok((pairs, colliding))
    }

    /// A body pair's friction from its geoms as MuJoCo combines them: the larger of the two
    /// geoms' sliding friction, none where both are frictionless (`condim="1"`); over a body's
    /// geoms, the largest. `None` when the scene sets `scm_friction`, which then applies to
    /// every pair without a `<pair friction>`.
    pub(super) fn geom_friction(&mut self, a: usize, b: usize, colliding: &[bool]) -> Option<f64> {
        if self.numeric.iter().any(|(n, _, _)| n == "scm_friction") {
            return None;
        }
        let over = self.friction_override();
        let combine = |x: &Geom, y: &Geom| {
            let (mu, condim) = mixed_contact(x, y, over);
            if condim == 1 {
                0.0
            } else {
                mu
            }
        };
        let values: Vec<f64> = self
            .geom_pairs(a, b, colliding)
            .into_iter()
            .map(|(x, y)| combine(x, y))
            .collect();
        let mu = values
            .iter()
            .copied()
            .fold(None, |m: Option<f64>, v| Some(m.map_or(v, |m| m.max(v))));
        if values.iter().any(|&v| Some(v) != mu) {
            let (na, nb) = (self.bodies[a].name.clone(), self.bodies[b].name.clone());
            let list = values
                .iter()
                .map(|v| v.to_string())
                .collect::<Vec<_>>()
                .join(", ");
            self.warnings.push(format!(
                "bodies '{na}' and '{nb}': their geoms combine to different friction coefficients ({list}); SCM's contact acts between whole bodies and uses the largest, {}",
                mu.unwrap_or(1.0)
            ));
        }
        Some(mu.unwrap_or(1.0))
    }

    /// A body pair's margin from its geoms as MuJoCo combines them: the sum of the two geoms'
    /// `margin` (whatever their priority); over a body's geoms, the largest, with a warning
    /// where they differ (SCM's contact acts between whole bodies).
    pub(super) fn geom_margin(&mut self, a: usize, b: usize, colliding: &[bool]) -> f64 {
        let values: Vec<f64> = self
            .geom_pairs(a, b, colliding)
            .into_iter()
            .map(|(x, y)| x.margin + y.margin)
            .collect();
        let largest = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if values.iter().any(|&v| v != largest) {
            let (na, nb) = (&self.bodies[a].name, &self.bodies[b].name);
            self.warnings.push(format!(
                "bodies '{na}' and '{nb}': their geoms' margins add up to different values ({}); SCM's contact acts between whole bodies and uses the largest, {largest} m",
                values.iter().map(|v| v.to_string()).collect::<Vec<_>>().join(", ")
            ));
        }
        if largest.is_finite() {
            largest
        } else {
            0.0
        }
    }

    /// A body pair's adhesion and gap from its geoms as MuJoCo's collision driver combines
    /// them per geom pair (adhesion: the sum, or the higher `priority`'s; gap: the sum); SCM's
    /// pair is between bodies, so the largest of each over its geom pairs, with a warning
    /// where they differ. `(0, 0)` without adhesive geoms.
    pub(super) fn geom_adhesion(&mut self, a: usize, b: usize, colliding: &[bool]) -> (f64, f64) {
        let values: Vec<(f64, f64)> = self
            .geom_pairs(a, b, colliding)
            .into_iter()
            .map(|(x, y)| {
                let (px, py) = (x.softness.priority, y.softness.priority);
                let adhesion = match px.cmp(&py) {
                    std::cmp::Ordering::Greater => x.adhesion,
                    std::cmp::Ordering::Less => y.adhesion,
                    std::cmp::Ordering::Equal => x.adhesion + y.adhesion,
                };
                (adhesion, x.gap + y.gap)
            })
            .collect();
        let largest = values
            .iter()
            .fold((0.0f64, 0.0f64), |m, v| (m.0.max(v.0), m.1.max(v.1)));
        if largest.0 > 0.0 && values.iter().any(|&v| v != largest) {
            let (na, nb) = (&self.bodies[a].name, &self.bodies[b].name);
            self.warnings.push(format!(
                "bodies '{na}' and '{nb}': their geom pairs have different adhesion or gap ({}); SCM's contact acts between whole bodies and uses the largest, adhesion {} N within a gap of {} m, so they pull wherever they come that near, not only at the adhesive geoms",
                values.iter().map(|v| format!("{} N, {} m", v.0, v.1)).collect::<Vec<_>>().join("; "),
                largest.0, largest.1
            ));
        }
        largest
    }

    /// `<flag override>`'s `o_friction`, where the flag is on.
    pub(super) fn friction_override(&self) -> Option<f64> {
        self.flags
            .override_contacts
            .then_some(self.contact_override.friction)
    }

    /// The geom pairs through which bodies `a` and `b` touch: those whose bits let them
    /// collide, or, for an explicit pair or whole-body contact past the bits, every pair of
    /// their colliding geoms.
    pub(super) fn geom_pairs(&self, a: usize, b: usize, colliding: &[bool]) -> Vec<(&Geom, &Geom)> {
        let of = |body: usize| -> Vec<&Geom> {
            self.geoms
                .iter()
                .zip(colliding)
                .filter(|(g, &c)| c && g.body == body)
                .map(|(g, _)| g)
                .collect()
        };
        let (ga, gb) = (of(a), of(b));
        let all = ga.iter().flat_map(|&x| gb.iter().map(move |&y| (x, y)));
        let compatible: Vec<_> = all
            .clone()
            .filter(|(x, y)| filter::compatible(x, y))
            .collect();
        if compatible.is_empty() {
            all.collect()
        } else {
            compatible
        }
    }
}

/// A geom pair's sliding friction and `condim` as MuJoCo's collision driver mixes them: the
/// geom of higher `priority` gives both whole; at equal priority the larger of each. Under
/// `<flag override>` (`over`: its `o_friction`) the friction is replaced, not the condim.
pub(super) fn mixed_contact(x: &Geom, y: &Geom, over: Option<f64>) -> (f64, u32) {
    let (px, py) = (x.softness.priority, y.softness.priority);
    let (mu, condim) = if px != py {
        let g = if px > py { x } else { y };
        (g.friction, g.condim)
    } else {
        (x.friction.max(y.friction), x.condim.max(y.condim))
    };
    (over.unwrap_or(mu), condim)
}

/// Why a geom has the spacing the scene's defaults gave it (`scm check`).
fn auto_reason(shape: &Shape, spacing: f64) -> String {
    let n = AUTO_RESOLUTION;
    let even = shape.spacing_within(spacing, n, AUTO_SAGITTA).fine;
    if let Some(m) = shape.mesh().filter(|_| even < spacing) {
        let thinnest = 2.0 * m.mass_properties().inertia_box().map_or(0.0, |b| b.x);
        format!(
            "the default for a thin mesh: {} points across its {thinnest:.4} m \
             thinnest extent",
            crate::geometry::shapes::MESH_POINTS_ACROSS
        )
    } else if shape.mesh().is_some() {
        "the default: a mesh's size does not tell its smallest feature".into()
    } else if even > spacing && shape.feature_length().max() / n <= even {
        format!(
            "the default for a smooth shape: {} mm sagitta on its {} m radius of curvature",
            AUTO_SAGITTA * 1e3,
            shape.feature_length().min()
        )
    } else if shape.feature_length().max() / n <= spacing {
        format!("the default: no larger than {n} spacings")
    } else {
        format!("graded: the default at its edges, its size / {n} inside")
    }
}

/// A geom's spacing for messages: one number when it samples evenly, else its fine spacing
/// and the coarse one per axis.
pub fn spacing_text(h: &Spacing) -> String {
    let c = h.coarse;
    if c.x == h.fine && c.y == h.fine && c.z == h.fine {
        format!("{} m", h.fine)
    } else {
        format!("{} m, up to {} × {} × {} m", h.fine, c.x, c.y, c.z)
    }
}

impl Builder {
    pub(super) fn contact(&mut self, el: &Element) -> Result<(), SceneError> {
        for c in &el.children {
            match c.name.as_str() {
                "pair" => {
                    self.check_attrs(
                        c,
                        &[
                            "name", "geom1", "geom2", "friction", "condim", "solref", "solimp",
                            "margin", "adhesion", "gap",
                        ],
                    )?;
                    let friction = self.friction_list(c, "friction", 5)?.map(|v| v[0]);
                    let condim = self.condim(c)?;
                    let friction = if condim == 1 { Some(0.0) } else { friction };
                    let g1 = c
                        .attr("geom1")
                        .ok_or_else(|| self.err(c, "geom1 is required"))?;
                    let g2 = c
                        .attr("geom2")
                        .ok_or_else(|| self.err(c, "geom2 is required"))?;
                    let softness = self.softness(c, contact::Softness::default())?;
                    let margin = self.float(c, "margin")?.unwrap_or(0.0);
                    let adhesion = self.float(c, "adhesion")?.unwrap_or(0.0);
                    let gap = self.float(c, "gap")?.unwrap_or(0.0);
                    if adhesion < 0.0 || gap < 0.0 {
                        return Err(self.err(c, "adhesion and gap must not be negative"));
                    }
                    self.explicit_pairs.push(ExplicitPair {
                        geoms: [g1.into(), g2.into()],
                        friction,
                        condim,
                        softness,
                        margin,
                        adhesion,
                        gap,
                        line: c.line,
                    });
                }
                "exclude" => {
                    self.check_attrs(c, &["name", "body1", "body2"])?;
                    let b1 = c
                        .attr("body1")
                        .ok_or_else(|| self.err(c, "body1 is required"))?;
                    let b2 = c
                        .attr("body2")
                        .ok_or_else(|| self.err(c, "body2 is required"))?;
                    self.excludes.push((b1.into(), b2.into(), c.line));
                }
                _ => return Err(self.err(c, "unsupported contact element")),
            }
        }
        Ok(())
    }
}
