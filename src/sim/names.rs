//! FMU variable names from MJCF names, legal under FMI 2.0's structured naming convention.
//!
//! A name made of letters, digits and underscores that does not start with a digit is used as
//! it is; any other name (spaces, hyphens, dots, a leading digit, non-ASCII letters) becomes a
//! quoted identifier, `'left arm'`, with `'` and `\` escaped by a backslash and control
//! characters written as FMI's escapes (`\n`, `\t`, ...). FMI 2.0 quoted names hold printable
//! ASCII only, so any other character is written as its code point in hex between tildes
//! (`λ` is `~3bb~`) and a tilde itself is doubled (`~~`). This is one-to-one, so distinct MJCF
//! names give distinct FMU names: `contact.'a.b'.c.force.x` and `contact.a.'b.c'.force.x`
//! differ.

/// The FMU form of one name component.
pub fn identifier(name: &str) -> String {
    let mut chars = name.chars();
    let plain = match chars.next() {
        Some(c) if c.is_ascii_alphabetic() || c == '_' => {
            chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
        }
        _ => false,
    };
    if plain {
        return name.to_string();
    }
    let mut out = String::with_capacity(name.len() + 2);
    out.push('\'');
    for c in name.chars() {
        match c {
            '\'' => out.push_str("\\'"),
            '\\' => out.push_str("\\\\"),
            '\u{7}' => out.push_str("\\a"),
            '\u{8}' => out.push_str("\\b"),
            '\u{c}' => out.push_str("\\f"),
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            '\t' => out.push_str("\\t"),
            '\u{b}' => out.push_str("\\v"),
            '~' => out.push_str("~~"),
            ' '..='~' => out.push(c),
            c => out.push_str(&format!("~{:x}~", c as u32)),
        }
    }
    out.push('\'');
    out
}

/// Makes every name of `names` unique, keeping the first of equal names as it is and
/// appending `_2`, `_3`, ... to the last component of the others (until unique). Returns the
/// renamed positions with their old names. With [`identifier`] on every component, only an
/// entity whose variables share a name with another kind's (a free joint and a mocap body of
/// the same name: both have `NAME.pos.x`) gets here.
pub fn make_unique(names: &mut [String]) -> Vec<(usize, String)> {
    let mut seen = std::collections::HashSet::new();
    let mut renamed = Vec::new();
    for i in 0..names.len() {
        if seen.insert(names[i].clone()) {
            continue;
        }
        let old = names[i].clone();
        let mut k = 2;
        let mut candidate = format!("{old}_{k}");
        while seen.contains(&candidate) || names.contains(&candidate) {
            k += 1;
            candidate = format!("{old}_{k}");
        }
        seen.insert(candidate.clone());
        names[i] = candidate;
        renamed.push((i, old));
    }
    renamed
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plain_names_stay_and_others_are_quoted() {
        assert_eq!(identifier("hinge_1"), "hinge_1");
        assert_eq!(identifier("left arm"), "'left arm'");
        assert_eq!(identifier("hinge-1"), "'hinge-1'");
        assert_eq!(identifier("1st"), "'1st'");
        assert_eq!(identifier("a.b"), "'a.b'");
        assert_eq!(identifier("it's"), "'it\\'s'");
        assert_eq!(identifier("back\\slash"), "'back\\\\slash'");
        assert_eq!(identifier("Gelenk_ä"), "'Gelenk_~e4~'");
        assert_eq!(identifier("a~b"), "'a~~b'");
        assert_eq!(identifier(""), "''");
    }

    #[test]
    fn quoting_keeps_distinct_names_distinct() {
        let names = [
            "a", "'a'", "a.b", "a b", "a\\", "a'", "\\'", "'", "λ", "~3bb~", "~~", "~", "\u{1}",
        ];
        let quoted: std::collections::HashSet<String> =
            names.iter().map(|n| identifier(n)).collect();
        assert_eq!(quoted.len(), names.len());
    }

    #[test]
    fn duplicates_get_a_suffix() {
        let mut v: Vec<String> = ["m.pos.x", "m.pos.x", "m.pos.x_2", "m.pos.x"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        let renamed = make_unique(&mut v);
        assert_eq!(v, ["m.pos.x", "m.pos.x_3", "m.pos.x_2", "m.pos.x_4"]);
        assert_eq!(renamed.len(), 2);
    }
}
