//! Reading elements: attributes as numbers and poses, the attributes SCM accepts or lists as
//! unused, stray text, and errors that name the file, the line and the element.

use super::*;

/// An error at an element: its file, line and name.
pub(super) fn element_error(el: &Element, message: impl Into<String>) -> SceneError {
    SceneError {
        file: el.file.to_string(),
        line: el.line,
        element: el.name.clone(),
        message: message.into(),
    }
}

/// Whitespace-separated finite numbers (`None` if any is not one).
pub(super) fn parse_floats(s: &str) -> Option<Vec<f64>> {
    s.split_whitespace()
        .map(|t| t.parse::<f64>().ok().filter(|x| x.is_finite()))
        .collect()
}

impl Builder {
    pub(super) fn err(&self, el: &Element, message: impl Into<String>) -> SceneError {
        element_error(el, message)
    }

    /// An element's `condim` (a geom's or a `<pair>`'s): 1, 3, 4 or 6, default 3.
    pub(super) fn condim(&self, el: &Element) -> Result<u32, SceneError> {
        match el.attr("condim") {
            None => Ok(3),
            Some(c) => c
                .trim()
                .parse()
                .ok()
                .filter(|c| [1, 3, 4, 6].contains(c))
                .ok_or_else(|| self.err(el, format!("condim=\"{c}\": expected 1, 3, 4 or 6"))),
        }
    }

    /// Rejects attributes outside `allowed`; those in [`UNUSED_ATTRIBUTES`] are accepted and
    /// noted as unused by SCM.
    pub(super) fn check_attrs(&mut self, el: &Element, allowed: &[&str]) -> Result<(), SceneError> {
        let mut unused = Vec::new();
        for (k, _) in &el.attrs {
            if allowed.contains(&k.as_str()) {
                continue;
            }
            match UNUSED_ATTRIBUTES.iter().find(|(a, _)| a == k) {
                Some((a, why)) => unused.push(format!("{a} ({why})")),
                None => {
                    return Err(self.err(
                        el,
                        format!(
                            "attribute '{k}' is not supported by SCM{}",
                            advice(&el.name, k)
                        ),
                    ))
                }
            }
        }
        if !unused.is_empty() {
            self.unused(el, unused.join(", "));
        }
        Ok(())
    }

    /// Notes that `what` of `el` is accepted and unused by SCM.
    pub(super) fn unused(&mut self, el: &Element, what: impl Into<String>) {
        self.unused.push(format!(
            "{}:{}: <{}> {}",
            el.file,
            el.line,
            el.name,
            what.into()
        ));
    }

    /// A friction list (`friction`, `o_friction`): 1 to `most` non-negative numbers, the
    /// sliding coefficient first (MuJoCo's torsional and rolling ones after it).
    pub(super) fn friction_list(
        &self,
        el: &Element,
        key: &str,
        most: usize,
    ) -> Result<Option<Vec<f64>>, SceneError> {
        match el.attr(key) {
            None => Ok(None),
            Some(s) => match parse_floats(s) {
                Some(v) if (1..=most).contains(&v.len()) && v[0] >= 0.0 => Ok(Some(v)),
                _ => Err(self.err(
                    el,
                    format!("{key}=\"{s}\": expected 1 to {most} non-negative numbers"),
                )),
            },
        }
    }

    pub(super) fn floats(
        &self,
        el: &Element,
        key: &str,
        n: usize,
    ) -> Result<Option<Vec<f64>>, SceneError> {
        match el.attr(key) {
            None => Ok(None),
            Some(s) => match parse_floats(s) {
                Some(v) if v.len() == n => Ok(Some(v)),
                _ => Err(self.err(el, format!("{key}=\"{s}\": expected {n} finite number(s)"))),
            },
        }
    }

    pub(super) fn float(&self, el: &Element, key: &str) -> Result<Option<f64>, SceneError> {
        Ok(self.floats(el, key, 1)?.map(|v| v[0]))
    }

    pub(super) fn vec3(&self, el: &Element, key: &str) -> Result<Option<Vector3<f64>>, SceneError> {
        Ok(self
            .floats(el, key, 3)?
            .map(|v| Vector3::new(v[0], v[1], v[2])))
    }

    pub(super) fn pose(&self, el: &Element) -> Result<Isometry3<f64>, SceneError> {
        canonical::pose(el, &self.angles)
    }

    /// Lists stray text between elements (a typing slip such as `</visual>>`) as unused:
    /// MuJoCo reads past it, and so does SCM, saying so. Before the tree is made canonical,
    /// which folds frames away.
    pub(super) fn stray_text(&mut self, root: &Element) {
        let mut stack = vec![root];
        while let Some(el) = stack.pop() {
            for (line, t) in &el.text {
                let shown: String = t.chars().take(40).collect();
                self.unused.push(format!(
                    "{}:{line}: text '{shown}' inside <{}> (MuJoCo ignores text between elements)",
                    el.file, el.name
                ));
            }
            stack.extend(el.children.iter().rev());
        }
    }

    /// An error in an SCM setting, naming its `<numeric>` or `<text>` element.
    pub(super) fn setting_error(&self, at: &Place, name: &str, message: String) -> SceneError {
        let element = if self.text.iter().any(|(n, _, p)| n == name && p == at) {
            "text"
        } else {
            "numeric"
        };
        SceneError {
            file: at.file.to_string(),
            line: at.line,
            element: element.into(),
            message: format!("{name}: {message}"),
        }
    }
}

/// Where an element was read: its file (the scene's, or the `<include>`d file that holds it)
/// and line, for messages about settings read before they are used.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Place {
    pub(super) file: Arc<str>,
    pub(super) line: usize,
}

impl Place {
    pub(super) fn of(el: &Element) -> Self {
        Place {
            file: el.file.clone(),
            line: el.line,
        }
    }
}

impl std::fmt::Display for Place {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}:{}", self.file, self.line)
    }
}
