//! The XML walk shared by the VTK readers (.vtu, .vti): the file's settings (header type, byte
//! order, appended data), its data arrays with their parents, and every other start tag with
//! its attributes.

use super::decode::{split_appended, Array, Layout, Stored};
use crate::io::text::perr;
use crate::Error;
use quick_xml::events::{BytesStart, Event};
use quick_xml::Reader;

/// A start tag other than DataArray: its local name, attributes and line.
pub(super) struct Tag {
    pub name: String,
    pub attrs: Vec<(String, String)>,
    pub line: usize,
}

impl Tag {
    /// The value of attribute `key`.
    pub fn get(&self, key: &str) -> Option<&str> {
        self.attrs.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str())
    }
}

/// What a VTK XML file holds, before it is read as a mesh or an image.
pub(super) struct Scanned<'a> {
    pub layout: Layout<'a>,
    pub arrays: Vec<Array>,
    pub tags: Vec<Tag>,
    pub last_line: usize,
}

/// Counts newlines incrementally so byte offsets turn into line numbers in linear time.
struct LineCounter<'a> {
    s: &'a [u8],
    pos: usize,
    line: usize,
}

impl LineCounter<'_> {
    fn at(&mut self, pos: usize) -> usize {
        let pos = pos.min(self.s.len());
        if pos > self.pos {
            self.line += self.s[self.pos..pos].iter().filter(|&&b| b == b'\n').count();
            self.pos = pos;
        }
        self.line
    }
}

fn attr(e: &BytesStart, key: &str) -> Option<String> {
    e.attributes()
        .flatten()
        .find(|a| a.key.local_name().as_ref() == key.as_bytes())
        .and_then(|a| a.unescape_value().ok().map(|v| v.into_owned()))
}

fn local(e: &BytesStart) -> String {
    String::from_utf8_lossy(e.local_name().as_ref()).into_owned()
}

/// Walks a VTK XML file whose VTKFile type must be `file_type`; one Piece at most.
pub(super) fn scan<'a>(bytes: &'a [u8], path: &'a str, file_type: &str) -> Result<Scanned<'a>, Error> {
    let (xml, appended) = split_appended(bytes, path)?;
    let s = xml.as_str();
    let mut layout = Layout { header_bytes: 4, big_endian: false, appended, path };
    let mut r = Reader::from_str(s);
    let mut lc = LineCounter { s: s.as_bytes(), pos: 0, line: 1 };
    let mut stack: Vec<String> = Vec::new();
    let mut arrays: Vec<Array> = Vec::new();
    let mut current: Option<Array> = None;
    let mut pieces = 0usize;
    let mut tags: Vec<Tag> = Vec::new();
    let mut saw_vtkfile = false;
    loop {
        let ev = r.read_event();
        let line = lc.at(r.buffer_position() as usize);
        let ev = ev.map_err(|e| perr(path, line, format!("malformed or truncated XML: {e}")))?;
        let (start, empty) = match &ev {
            Event::Start(e) => (Some(e.clone()), false),
            Event::Empty(e) => (Some(e.clone()), true),
            _ => (None, false),
        };
        if let Some(e) = start {
            let name = local(&e);
            match name.as_str() {
                "VTKFile" => {
                    saw_vtkfile = true;
                    let t = attr(&e, "type").unwrap_or_default();
                    if t != file_type {
                        return Err(perr(path, line, format!("VTKFile type {t:?} is not {file_type}")));
                    }
                    if attr(&e, "compressor").is_some() {
                        return Err(perr(path, line, "compressed vtu data not supported"));
                    }
                    layout.header_bytes = match attr(&e, "header_type").as_deref() {
                        None | Some("UInt32") => 4,
                        Some("UInt64") => 8,
                        Some(h) => return Err(perr(path, line, format!("header_type {h:?} is not UInt32 or UInt64"))),
                    };
                    layout.big_endian = match attr(&e, "byte_order").as_deref() {
                        None | Some("LittleEndian") => false,
                        Some("BigEndian") => true,
                        Some(b) => return Err(perr(path, line, format!("byte_order {b:?} is not known"))),
                    };
                }
                "Piece" => {
                    pieces += 1;
                    if pieces > 1 {
                        return Err(perr(path, line, "VTK files with several pieces are not supported"));
                    }
                }
                "DataArray" => {
                    if current.is_some() {
                        return Err(perr(path, line, "DataArray nested inside DataArray"));
                    }
                    let format = attr(&e, "format").unwrap_or_else(|| "ascii".into());
                    let stored = match format.as_str() {
                        "ascii" => Stored::Ascii,
                        "binary" => Stored::Base64,
                        "appended" => Stored::Appended(
                            attr(&e, "offset")
                                .and_then(|v| v.trim().parse::<usize>().ok())
                                .ok_or_else(|| perr(path, line, "an appended DataArray needs a valid offset"))?,
                        ),
                        f => return Err(perr(path, line, format!("DataArray format {f:?} is not known"))),
                    };
                    let components = match attr(&e, "NumberOfComponents") {
                        None => 1,
                        Some(v) => v
                            .trim()
                            .parse::<usize>()
                            .ok()
                            .filter(|&c| (1..=64).contains(&c))
                            .ok_or_else(|| perr(path, line, format!("bad NumberOfComponents {v:?}")))?,
                    };
                    let a = Array {
                        parent: stack.last().cloned().unwrap_or_default(),
                        name: attr(&e, "Name").unwrap_or_default(),
                        components,
                        text: String::new(),
                        line,
                        stored,
                        vtk_type: attr(&e, "type").unwrap_or_default(),
                    };
                    if empty {
                        arrays.push(a);
                    } else {
                        current = Some(a);
                    }
                }
                _ => {}
            }
            if name != "DataArray" {
                let attrs = e
                    .attributes()
                    .flatten()
                    .filter_map(|a| {
                        let k = String::from_utf8_lossy(a.key.local_name().as_ref()).into_owned();
                        a.unescape_value().ok().map(|v| (k, v.into_owned()))
                    })
                    .collect();
                tags.push(Tag { name: name.clone(), attrs, line });
            }
            if !empty {
                stack.push(name);
            }
            continue;
        }
        match ev {
            Event::End(e) => {
                let name = String::from_utf8_lossy(e.local_name().as_ref()).into_owned();
                if stack.pop().as_deref() != Some(name.as_str()) {
                    return Err(perr(path, line, format!("unexpected closing tag </{name}>")));
                }
                if name == "DataArray" {
                    if let Some(a) = current.take() {
                        arrays.push(a);
                    }
                }
            }
            Event::Text(t) => {
                if let Some(a) = current.as_mut() {
                    let txt = t.unescape().map_err(|e| perr(path, line, format!("bad text in DataArray: {e}")))?;
                    if a.text.is_empty() {
                        // The array's text starts where its start tag ended.
                        a.line = lc.line - txt.matches('\n').count();
                    }
                    a.text.push_str(&txt);
                }
            }
            Event::CData(_) if current.is_some() => {
                return Err(perr(path, line, "CDATA in a DataArray is not supported"));
            }
            Event::Eof => break,
            _ => {}
        }
    }
    let last_line = lc.line;
    if !saw_vtkfile {
        return Err(perr(path, 1, "not a VTK XML file (no VTKFile element)"));
    }
    if !stack.is_empty() {
        return Err(perr(path, last_line, format!("file ends inside <{}> (truncated)", stack.join("><"))));
    }
    Ok(Scanned { layout, arrays, tags, last_line })
}
