//! LZF decompression, as PCD's `binary_compressed` bodies need it.
//!
//! Follows Marc Lehmann's liblzf (`lzf_d.c`, version 3.6), the codec PCL uses. The decoder is a
//! few dozen lines, so it is written here, every read and copy bounds-checked, rather than taken
//! as a dependency.

/// The most one LZF input byte can expand to: a 3-byte back reference copies at most 264 bytes.
pub(super) const LZF_MAX_RATIO: u64 = 88;

/// Why an LZF stream could not be expanded.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(super) struct LzfError {
    /// Offset in the compressed input of the instruction at fault.
    pub(super) input_offset: usize,
    /// What went wrong.
    pub(super) what: String,
}

/// Expands an LZF stream (Marc Lehmann's liblzf format, `lzf_d.c`) that must produce exactly
/// `out_len` bytes.
///
/// The stream is a sequence of instructions, each starting with a control byte `c`:
/// * `c < 32`: a literal run; the next `c + 1` bytes are copied as they are;
/// * otherwise a back reference: `len = c >> 5` (if 7, add the next byte), `off = (c & 31) << 8`
///   plus the next byte; copy `len + 2` bytes starting `off + 1` bytes back in the output
///   (the ranges may overlap, which repeats a pattern).
pub(super) fn lzf_decompress(input: &[u8], out_len: usize) -> Result<Vec<u8>, LzfError> {
    let mut out = Vec::with_capacity(out_len);
    let mut ip = 0usize;
    let err = |at: usize, what: String| LzfError { input_offset: at, what };
    while ip < input.len() {
        let at = ip;
        let ctrl = usize::from(input[ip]);
        ip += 1;
        if ctrl < 32 {
            let run = ctrl + 1;
            let lit = input
                .get(ip..ip + run)
                .ok_or_else(|| err(at, format!("literal run of {run} bytes passes the end of the input")))?;
            if out.len() + run > out_len {
                return Err(err(at, format!("output exceeds the declared {out_len} bytes")));
            }
            out.extend_from_slice(lit);
            ip += run;
        } else {
            let mut len = ctrl >> 5;
            if len == 7 {
                len += usize::from(*input.get(ip).ok_or_else(|| err(at, "back reference cut short".into()))?);
                ip += 1;
            }
            let low = usize::from(*input.get(ip).ok_or_else(|| err(at, "back reference cut short".into()))?);
            ip += 1;
            let back = ((ctrl & 0x1f) << 8) + low + 1;
            let len = len + 2;
            if back > out.len() {
                return Err(err(
                    at,
                    format!("back reference {back} bytes back, but only {} bytes were produced", out.len()),
                ));
            }
            if out.len() + len > out_len {
                return Err(err(at, format!("output exceeds the declared {out_len} bytes")));
            }
            let from = out.len() - back;
            if back >= len {
                out.extend_from_within(from..from + len);
            } else {
                for k in 0..len {
                    let b = out[from + k];
                    out.push(b);
                }
            }
        }
    }
    if out.len() != out_len {
        return Err(err(input.len(), format!("stream expands to {} bytes, {out_len} were declared", out.len())));
    }
    Ok(out)
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The simplest valid LZF encoder: literal runs of at most 32 bytes.
    pub(in crate::pcd) fn literal_runs(data: &[u8]) -> Vec<u8> {
        let mut out = Vec::new();
        for chunk in data.chunks(32) {
            out.push((chunk.len() - 1) as u8);
            out.extend_from_slice(chunk);
        }
        out
    }

    #[test]
    fn lzf_back_references_and_errors() {
        // "abcabcabcab": literal "abc", then a reference 3 back of length 8 (ctrl (6 << 5) | 0, low 2).
        let z = [2, b'a', b'b', b'c', 6 << 5, 2];
        assert_eq!(lzf_decompress(&z, 11).unwrap(), b"abcabcabcab");
        // Long reference: len 7 + 3 + 2 = 12 bytes of 'x' one back.
        assert_eq!(lzf_decompress(&[0, b'x', 7 << 5, 3, 0], 13).unwrap(), vec![b'x'; 13]);
        assert!(lzf_decompress(&[6 << 5, 0], 8).is_err(), "reference before any output");
        assert!(lzf_decompress(&[5, 1, 2], 6).is_err(), "literal past the end");
        assert!(lzf_decompress(&z, 10).is_err(), "more output than declared");
        assert!(lzf_decompress(&z, 12).is_err(), "less output than declared");
        assert!(lzf_decompress(&[0, 1, 7 << 5], 20).is_err(), "cut reference");
    }

    proptest! {
        #[test]
        fn lzf_never_panics(input in proptest::collection::vec(any::<u8>(), 0..300), n in 0usize..2000) {
            let _ = lzf_decompress(&input, n);
        }

        #[test]
        fn lzf_literal_round_trip(data in proptest::collection::vec(any::<u8>(), 0..300)) {
            prop_assert_eq!(lzf_decompress(&literal_runs(&data), data.len()).unwrap(), data);
        }

    }
}
