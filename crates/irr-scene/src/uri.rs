//! The two URI forms a glTF buffer may use: `data:` URIs with base64 payloads (RFC 2397, RFC 4648
//! §4) and relative references with percent-encoding (RFC 3986 §2.1). Small enough to own, so
//! every failure becomes a precise error rather than a panic in a dependency.

/// A problem with a URI, described for the user.
pub(crate) type UriError = String;

/// The payload of a `data:` URI, if `uri` is one: `data:[<mediatype>];base64,<payload>`.
///
/// Returns `None` for a URI that is not a data URI, `Some(Err)` for a data URI that is not
/// base64 or whose payload is malformed.
pub(crate) fn decode_data_uri(uri: &str) -> Option<Result<Vec<u8>, UriError>> {
    let rest = uri.strip_prefix("data:")?;
    let Some((header, payload)) = rest.split_once(',') else {
        return Some(Err("data URI has no ',' before its payload".to_string()));
    };
    if !header.ends_with(";base64") {
        return Some(Err(format!(
            "data URI with media type '{header}' is not base64-encoded"
        )));
    }
    Some(decode_base64(payload))
}

/// The value of one base64 digit (RFC 4648 table 1), or `None` for any other byte.
fn digit(c: u8) -> Option<u32> {
    match c {
        b'A'..=b'Z' => Some(u32::from(c - b'A')),
        b'a'..=b'z' => Some(u32::from(c - b'a') + 26),
        b'0'..=b'9' => Some(u32::from(c - b'0') + 52),
        b'+' => Some(62),
        b'/' => Some(63),
        _ => None,
    }
}

/// Decodes standard base64; the trailing `=` padding is optional (some exporters drop it).
pub(crate) fn decode_base64(text: &str) -> Result<Vec<u8>, UriError> {
    let bytes = text.trim_end_matches('=').as_bytes();
    if text.len() - bytes.len() > 2 {
        return Err("base64 payload has more than two '=' padding characters".to_string());
    }
    if bytes.len() % 4 == 1 {
        return Err(format!(
            "base64 payload of {} digits is truncated (a group cannot have one digit)",
            bytes.len()
        ));
    }
    let mut out = Vec::with_capacity(bytes.len() / 4 * 3 + 2);
    for (g, group) in bytes.chunks(4).enumerate() {
        let mut acc = 0u32;
        for (i, &c) in group.iter().enumerate() {
            let v = digit(c).ok_or_else(|| {
                format!(
                    "base64 payload has an invalid character {:?} at position {}",
                    char::from(c),
                    g * 4 + i
                )
            })?;
            acc |= v << (18 - 6 * i);
        }
        // A group of n digits carries n·6 bits: 4 digits → 3 bytes, 3 → 2, 2 → 1.
        let [_, b0, b1, b2] = acc.to_be_bytes();
        let n = group.len() - 1;
        out.extend_from_slice(&[b0, b1, b2][..n]);
    }
    Ok(out)
}

/// The scheme of `uri` (RFC 3986 §3.1: letters, digits, '+', '-', '.' before the first ':'),
/// if it has one: a relative file reference has none.
pub(crate) fn scheme(uri: &str) -> Option<&str> {
    let (scheme, _) = uri.split_once(':')?;
    (!scheme.is_empty()
        && scheme
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "+-.".contains(c)))
    .then_some(scheme)
}

/// Decodes `%XX` escapes in a relative URI reference into the file name they stand for.
pub(crate) fn percent_decode(uri: &str) -> Result<String, UriError> {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = bytes
                .get(i + 1..i + 3)
                .and_then(|h| std::str::from_utf8(h).ok())
                .and_then(|h| u8::from_str_radix(h, 16).ok())
                .ok_or_else(|| format!("URI '{uri}' has a malformed '%' escape at byte {i}"))?;
            out.push(hex);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).map_err(|_| format!("URI '{uri}' decodes to bytes that are not UTF-8"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    // The test helpers' base64 encoder (RFC 4648 §4), independent of the decoder under test.
    use crate::testutil::base64 as encode;

    #[test]
    fn rfc4648_test_vectors() {
        // RFC 4648 §10.
        for (plain, coded) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(decode_base64(coded).as_deref(), Ok(plain.as_bytes()));
            assert_eq!(encode(plain.as_bytes()), coded);
        }
    }

    #[test]
    fn malformed_payloads_are_errors() {
        assert!(decode_base64("Zm9v!").is_err());
        assert!(decode_base64("Z").is_err());
        assert!(decode_base64("Zg===").is_err());
        assert!(decode_data_uri("data:application/octet-stream,abc").is_some_and(|r| r.is_err()));
        assert!(decode_data_uri("data:abc").is_some_and(|r| r.is_err()));
        assert!(decode_data_uri("box.bin").is_none());
    }

    #[test]
    fn percent_escapes() {
        assert_eq!(percent_decode("my%20box.bin").as_deref(), Ok("my box.bin"));
        assert_eq!(percent_decode("plain.bin").as_deref(), Ok("plain.bin"));
        assert!(percent_decode("bad%2").is_err());
        assert!(percent_decode("bad%zz").is_err());
        assert!(percent_decode("%ff").is_err());
    }

    proptest! {
        #[test]
        fn base64_round_trips(data in proptest::collection::vec(any::<u8>(), 0..200)) {
            let uri = format!("data:application/octet-stream;base64,{}", encode(&data));
            prop_assert_eq!(decode_data_uri(&uri), Some(Ok(data)));
        }

        #[test]
        fn arbitrary_text_never_panics(text in ".{0,64}") {
            let _ = decode_base64(&text);
            let _ = percent_decode(&text);
        }
    }
}
