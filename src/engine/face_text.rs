//! The text formats of the vendored face model (`stimuli/face/`), read by the build script,
//! which bakes them into the binary form [`crate::engine::asset`] loads at run time.
//!
//! In: `head.obj` (parts as `o` blocks, `v` vertices, triangular `f` faces) and row files
//! (`index value…`: targets, regions, the mirror map). Out: plain vectors, or the line and the
//! reason a file is malformed. Invariant: std only (the build script compiles this file on its
//! own), and the same text always gives the same numbers, so baking changes no render.

/// A malformed line: its 1-based number and what is wrong.
pub type LineError = (usize, String);

/// One `o` block of `head.obj`: its name and its triangles (0-based indices).
pub struct ObjPart {
    pub name: String,
    pub triangles: Vec<[u32; 3]>,
}

/// Reads `head.obj`: the vertices and the parts in file order.
pub fn parse_obj(text: &str) -> Result<(Vec<[f32; 3]>, Vec<ObjPart>), LineError> {
    let mut positions = Vec::new();
    let mut parts: Vec<ObjPart> = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let malformed = |message: &str| (n + 1, message.to_string());
        let mut fields = line.split_whitespace();
        match fields.next() {
            Some("v") => {
                let xyz: Vec<f32> = fields.map(str::parse).collect::<Result<_, _>>().map_err(|e| malformed(&format!("{e}")))?;
                let [x, y, z] = xyz[..] else { return Err(malformed("a vertex needs three coordinates")) };
                positions.push([x, y, z]);
            }
            Some("o") => parts.push(ObjPart { name: fields.next().unwrap_or_default().to_string(), triangles: Vec::new() }),
            Some("f") => {
                let corners: Vec<u32> = fields
                    .map(|f| f.split('/').next().and_then(|v| v.parse::<u32>().ok()).and_then(|v| v.checked_sub(1)))
                    .collect::<Option<_>>()
                    .ok_or_else(|| malformed("bad face"))?;
                let [a, b, c] = corners[..] else { return Err(malformed("faces must be triangles")) };
                let part = parts.last_mut().ok_or_else(|| malformed("face before any part"))?;
                part.triangles.push([a, b, c]);
            }
            _ => {}
        }
    }
    Ok((positions, parts))
}

/// Reads `index value…` rows (blank lines and `#` comments skipped); every row must carry
/// exactly `width` values after its index.
pub fn parse_rows(text: &str, width: usize) -> Result<Vec<(u32, Vec<f32>)>, LineError> {
    let mut rows = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let malformed = |message: &str| (n + 1, message.to_string());
        let mut fields = line.split_whitespace();
        let index: u32 = fields.next().and_then(|f| f.parse().ok()).ok_or_else(|| malformed("expected a vertex index"))?;
        let values: Vec<f32> = fields.map(str::parse).collect::<Result<_, _>>().map_err(|_| malformed("expected numbers"))?;
        if values.len() != width {
            return Err(malformed("wrong number of values"));
        }
        rows.push((index, values));
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn obj_parts_keep_their_triangles_and_bad_lines_are_named() {
        let (positions, parts) = parse_obj("o skin\nv 0 1 2\nv 1 1 2\nv 0 0 2\nf 1/1 2/2 3/3\n").unwrap();
        assert_eq!(positions, vec![[0.0, 1.0, 2.0], [1.0, 1.0, 2.0], [0.0, 0.0, 2.0]]);
        assert_eq!((parts[0].name.as_str(), parts[0].triangles.clone()), ("skin", vec![[0, 1, 2]]));
        assert_eq!(parse_obj("o skin\nv 0 1\n").err(), Some((2, "a vertex needs three coordinates".into())));
        assert_eq!(parse_obj("v 0 1 2\nf 1 2 3\n").err(), Some((2, "face before any part".into())));
        assert_eq!(parse_obj("o skin\nf 0 1 2\n").err(), Some((2, "bad face".into())));
    }

    #[test]
    fn rows_need_their_width() {
        assert_eq!(parse_rows("# c\n\n3 0.5 -1 2\n", 3).unwrap(), vec![(3, vec![0.5, -1.0, 2.0])]);
        assert_eq!(parse_rows("3 0.5\n4 x\n", 1).err(), Some((2, "expected numbers".into())));
        assert_eq!(parse_rows("3 0.5 1\n", 1).err(), Some((1, "wrong number of values".into())));
    }
}
