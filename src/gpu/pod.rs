//! Plain-old-data values that travel to the GPU as bytes: push constants, uniform and storage
//! buffer contents, vertices. Every pass's `repr(C)` mirror of a GLSL interface implements
//! [`Pod`] and is uploaded through [`as_bytes`].

/// Plain-old-data that may be viewed as bytes.
///
/// # Safety
/// Implementors are `#[repr(C)]`, `Copy`, and have no padding bytes.
pub unsafe trait Pod: Copy {}

// SAFETY: primitive numbers and arrays of them have no padding.
unsafe impl Pod for f32 {}
// SAFETY: as above.
unsafe impl Pod for u32 {}
// SAFETY: arrays of Pod have no padding between elements.
unsafe impl<T: Pod, const N: usize> Pod for [T; N] {}

/// The bytes of a slice of plain-old-data values.
pub fn as_bytes<T: Pod>(values: &[T]) -> &[u8] {
    // SAFETY: T is Pod (no padding, no pointers); the slice is valid for its length.
    unsafe { std::slice::from_raw_parts(values.as_ptr().cast(), std::mem::size_of_val(values)) }
}

/// (name, offset, size) of the members of the GLSL block or struct whose declaration starts with
/// `head` in `glsl`, laid out by the std430 / push-constant rules, for the member types the
/// interfaces use. Test support: each pass's `repr(C)` mirror is checked against its shader.
#[cfg(test)]
pub fn glsl_block(glsl: &str, head: &str) -> Vec<(String, usize, usize)> {
    let start = glsl
        .find(head)
        .unwrap_or_else(|| panic!("no `{head}` in the GLSL"));
    let body = &glsl[start..];
    let open = body.find('{').expect("block opens");
    let close = body.find('}').expect("block closes");
    let mut offset = 0usize;
    body[open + 1..close]
        .lines()
        .map(|l| l.split("//").next().unwrap_or("").trim())
        .filter(|l| !l.is_empty())
        .map(|l| {
            let mut parts = l.trim_end_matches(';').split_whitespace();
            let ty = parts.next().expect("type");
            let name = parts.next().expect("name").to_string();
            let (size, align): (usize, usize) = match ty {
                "mat4" => (64, 16),
                "vec4" | "uvec4" => (16, 16),
                "vec2" => (8, 8),
                "uint" | "float" => (4, 4),
                other => panic!("unexpected GLSL type {other}"),
            };
            offset = offset.next_multiple_of(align);
            let here = offset;
            offset += size;
            (name, here, size)
        })
        .collect()
}
