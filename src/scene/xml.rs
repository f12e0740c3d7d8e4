//! A small element tree over quick-xml, keeping each element's line for error messages.

use quick_xml::events::{BytesStart, Event};
use quick_xml::Reader;
use std::sync::Arc;

/// An XML element with its attributes (in document order), children and source line.
#[derive(Clone, Debug, PartialEq)]
pub struct Element {
    /// Tag name.
    pub name: String,
    /// Attributes, unescaped.
    pub attrs: Vec<(String, String)>,
    /// Child elements.
    pub children: Vec<Element>,
    /// 1-based line of the start tag.
    pub line: usize,
    /// The file the element was read from (an `<include>`d file names its own).
    pub file: Arc<str>,
    /// Text directly inside the element other than white space (line, trimmed text): no MJCF
    /// element has any, and MuJoCo ignores it; the loader lists it as unused.
    pub text: Vec<(usize, String)>,
}

impl Element {
    /// Value of an attribute.
    pub fn attr(&self, key: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }
}

/// A parse error with its 1-based line.
#[derive(Debug, Clone, PartialEq)]
pub struct XmlError {
    /// Line of the error.
    pub line: usize,
    /// What is wrong.
    pub message: String,
}

fn line_of(text: &str, pos: usize) -> usize {
    text.as_bytes()[..pos.min(text.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

fn element(text: &str, file: &Arc<str>, e: &BytesStart, pos: usize) -> Result<Element, XmlError> {
    let line = line_of(text, pos);
    let qname = e.name();
    let name: String = {
        let n: &str = qname.as_ref();
        n.to_owned()
    };
    let mut attrs = Vec::new();
    for a in e.attributes() {
        let a = a.map_err(|err| XmlError {
            line,
            message: format!("bad attribute in <{name}>: {err}"),
        })?;
        let key: String = {
            let k: &str = a.key.as_ref();
            k.to_owned()
        };
        let value = a
            .normalized_value(quick_xml::XmlVersion::Implicit1_0)
            .map_err(|err| XmlError {
                line,
                message: format!("bad value of {key} in <{name}>: {err}"),
            })?
            .into_owned();
        if attrs.iter().any(|(k, _)| *k == key) {
            return Err(XmlError {
                line,
                message: format!("attribute {key} repeated in <{name}>"),
            });
        }
        attrs.push((key, value));
    }
    Ok(Element {
        name,
        attrs,
        children: Vec::new(),
        line,
        file: file.clone(),
        text: Vec::new(),
    })
}

/// Parses a document into its root element; `file` names it in every element.
pub fn parse(text: &str, file: &str) -> Result<Element, XmlError> {
    let file: Arc<str> = Arc::from(file);
    let mut reader = Reader::from_str(text);
    reader.config_mut().check_end_names = true;
    let mut stack: Vec<Element> = Vec::new();
    let mut root = None;
    loop {
        let pos = reader.buffer_position() as usize;
        let ev = reader.read_event().map_err(|e| XmlError {
            line: line_of(text, reader.error_position() as usize),
            message: e.to_string(),
        })?;
        match ev {
            Event::Start(e) => stack.push(element(text, &file, &e, pos)?),
            Event::Empty(e) => {
                let el = element(text, &file, &e, pos)?;
                match stack.last_mut() {
                    Some(parent) => parent.children.push(el),
                    None if root.is_none() => root = Some(el),
                    None => {
                        return Err(XmlError {
                            line: el.line,
                            message: "more than one root element".into(),
                        })
                    }
                }
            }
            Event::End(_) => {
                let el = stack.pop().expect("quick-xml checks end names");
                match stack.last_mut() {
                    Some(parent) => parent.children.push(el),
                    None if root.is_none() => root = Some(el),
                    None => {
                        return Err(XmlError {
                            line: el.line,
                            message: "more than one root element".into(),
                        })
                    }
                }
            }
            Event::Text(t) => {
                let s: String = {
                    let raw: &str = t.as_ref();
                    raw.to_owned()
                };
                if !s.trim().is_empty() {
                    match stack.last_mut() {
                        Some(parent) => parent.text.push((line_of(text, pos), s.trim().into())),
                        None => {
                            return Err(XmlError {
                                line: line_of(text, pos),
                                message: format!("text '{}' outside the root element", s.trim()),
                            })
                        }
                    }
                }
            }
            Event::Eof => break,
            _ => {}
        }
    }
    if let Some(open) = stack.last() {
        return Err(XmlError {
            line: open.line,
            message: format!("<{}> is never closed", open.name),
        });
    }
    root.ok_or(XmlError {
        line: 1,
        message: "no root element".into(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeps_lines_and_attributes() {
        let doc = parse(
            "<a>\n  <b x=\"1 &amp; 2\"/>\n  <c>\n    <d/>\n  </c>\n</a>",
            "t.xml",
        )
        .unwrap();
        assert_eq!(doc.children[0].attr("x"), Some("1 & 2"));
        assert_eq!(doc.children[0].line, 2);
        assert_eq!(doc.children[1].children[0].line, 4);
    }

    #[test]
    fn reports_the_line_of_an_error() {
        let err = parse("<a>\n<b>\n</a>", "t.xml").unwrap_err();
        assert!(err.line >= 2, "{err:?}");
        assert_eq!(
            parse("<a/><b/>", "t.xml").unwrap_err().message,
            "more than one root element"
        );
        assert!(parse("<a>\n<b/>\n", "t.xml")
            .unwrap_err()
            .message
            .contains("never closed"));
    }

    /// Text between elements (MuJoCo reads past it) is kept with its line for the loader to
    /// list; text outside the root is a malformed document.
    #[test]
    fn keeps_stray_text_with_its_line() {
        let doc = parse("<a>\n  <b/>>\n  <c> x </c>\n</a>", "t.xml").unwrap();
        assert_eq!(doc.text, [(2, ">".to_string())]);
        assert_eq!(doc.children[1].text, [(3, "x".to_string())]);
        assert!(parse("<a/>\ny", "t.xml").is_err());
    }
}
