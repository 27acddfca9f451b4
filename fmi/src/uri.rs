//! `fmuResourceLocation` URIs ↔ paths.
//!
//! Importers differ: fmpy passes `file:///tmp/x/resources` (percent-encoded), OMSimulator
//! `file:////tmp/x/resources`, others `file://localhost/...` or a trailing slash.

use std::path::PathBuf;

/// The directory a resource-location URI names; `Ok(None)` for a null or empty location.
pub(crate) fn resource_dir(uri: &str) -> Result<Option<PathBuf>, String> {
    let uri = uri.trim();
    if uri.is_empty() {
        return Ok(None);
    }
    let Some(rest) = strip_prefix_ignore_case(uri, "file:") else {
        return Err(format!("resource location `{uri}` is not a file: URI"));
    };
    // `file:/abs`, `file:///abs`, `file:////abs` and `file://localhost/abs` all name /abs.
    let path = if let Some(after) = rest.strip_prefix("//") {
        if after.starts_with('/') {
            after
        } else if let Some(p) = strip_prefix_ignore_case(after, "localhost") {
            if !p.starts_with('/') {
                return Err(format!("resource location `{uri}`: expected a path after `localhost`"));
            }
            p
        } else {
            let host = after.split('/').next().unwrap_or("");
            return Err(format!("resource location `{uri}`: remote host `{host}` is not supported"));
        }
    } else if rest.starts_with('/') {
        rest
    } else {
        return Err(format!("resource location `{uri}`: the path must be absolute"));
    };
    // Collapse the leading slashes of `file:////abs`.
    let path = format!("/{}", path.trim_start_matches('/'));
    let decoded = percent_decode(&path).map_err(|e| format!("resource location `{uri}`: {e}"))?;
    let trimmed = if decoded.len() > 1 { decoded.trim_end_matches('/') } else { &decoded };
    Ok(Some(PathBuf::from(trimmed)))
}

fn strip_prefix_ignore_case<'a>(s: &'a str, prefix: &str) -> Option<&'a str> {
    let head = s.get(..prefix.len())?;
    head.eq_ignore_ascii_case(prefix).then(|| &s[prefix.len()..])
}

/// Decode `%XX` escapes; the result must be UTF-8.
pub(crate) fn percent_decode(s: &str) -> Result<String, String> {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = bytes.get(i + 1..i + 3).and_then(|h| std::str::from_utf8(h).ok());
            match hex.and_then(|h| u8::from_str_radix(h, 16).ok()) {
                Some(b) => out.push(b),
                None => return Err(format!("bad percent escape at byte {i}")),
            }
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).map_err(|_| "the decoded text is not UTF-8".to_owned())
}

/// `file:///abs/path` with every byte outside `A-Za-z0-9-._~/` percent-encoded.
pub fn file_uri(path: &std::path::Path) -> String {
    use std::os::unix::ffi::OsStrExt;
    let mut out = String::from("file://");
    for &b in path.as_os_str().as_bytes() {
        if b.is_ascii_alphanumeric() || b"-._~/".contains(&b) {
            out.push(b as char);
        } else {
            out.push_str(&format!("%{b:02X}"));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(uri: &str) -> PathBuf {
        resource_dir(uri).unwrap().unwrap()
    }

    #[test]
    fn the_forms_importers_use() {
        assert_eq!(dir("file:///tmp/x/resources"), PathBuf::from("/tmp/x/resources"));
        assert_eq!(dir("file:///tmp/x/resources/"), PathBuf::from("/tmp/x/resources"));
        assert_eq!(dir("file:////tmp/x/resources"), PathBuf::from("/tmp/x/resources"));
        assert_eq!(dir("file://localhost/tmp/x/resources/"), PathBuf::from("/tmp/x/resources"));
        assert_eq!(dir("file:/tmp/x"), PathBuf::from("/tmp/x"));
        assert_eq!(dir("FILE:///tmp/x"), PathBuf::from("/tmp/x"));
        assert_eq!(dir("file:///"), PathBuf::from("/"));
    }

    #[test]
    fn percent_encoding() {
        assert_eq!(dir("file:///tmp/a%20b/res%25x"), PathBuf::from("/tmp/a b/res%x"));
        assert_eq!(dir("file:///tmp/%E6%97%A5"), PathBuf::from("/tmp/日"));
        assert!(resource_dir("file:///tmp/%zz").unwrap_err().contains("bad percent escape"));
        assert!(resource_dir("file:///tmp/%4").is_err());
        assert!(resource_dir("file:///tmp/%FF").unwrap_err().contains("UTF-8"));
    }

    #[test]
    fn empty_and_invalid() {
        assert_eq!(resource_dir("").unwrap(), None);
        assert_eq!(resource_dir("  ").unwrap(), None);
        assert!(resource_dir("http://x/y").unwrap_err().contains("not a file: URI"));
        assert!(resource_dir("file://server/share").unwrap_err().contains("remote host `server`"));
        assert!(resource_dir("file:relative/dir").unwrap_err().contains("absolute"));
    }

    #[test]
    fn file_uri_round_trips() {
        for p in ["/tmp/plain", "/tmp/with space/and%percent", "/tmp/ünï/[x]"] {
            let uri = file_uri(std::path::Path::new(p));
            assert!(uri.starts_with("file:///"));
            assert_eq!(dir(&uri), PathBuf::from(p), "{uri}");
        }
    }
}

/// A text handed over in a String parameter instead of a file name: a `data:` URI (RFC 2397)
/// of the media type, with a `name` parameter that messages show, the text percent-encoded.
pub fn data_uri(media_type: &str, name: &str, text: &str) -> String {
    let mut out = format!("data:{media_type};name={},", percent_encode(name, b"-._~"));
    out.push_str(&percent_encode(text, b"-._~!*'();/?:@&=+$"));
    out
}

/// Every byte outside `A-Za-z0-9` and `keep` percent-encoded.
fn percent_encode(text: &str, keep: &[u8]) -> String {
    let mut out = String::with_capacity(text.len() + text.len() / 4);
    for &b in text.as_bytes() {
        if b.is_ascii_alphanumeric() || keep.contains(&b) {
            out.push(b as char);
        } else {
            out.push_str(&format!("%{b:02X}"));
        }
    }
    out
}

/// Whether `s` is a `data:` URI (well formed or not).
pub fn is_data_uri(s: &str) -> bool {
    strip_prefix_ignore_case(s, "data:").is_some()
}

/// A `data:` URI's text and its `name` parameter (empty if it has none); `None` if `s` is not a
/// `data:` URI. Only the percent-encoded form is read (not `;base64`).
pub fn parse_data_uri(s: &str) -> Option<Result<(String, String), String>> {
    let rest = strip_prefix_ignore_case(s, "data:")?;
    Some((|| {
        let (header, data) = rest.split_once(',').ok_or("a data: URI needs a comma before its data")?;
        let mut name = String::new();
        for parameter in header.split(';').skip(1) {
            match parameter.split_once('=') {
                Some(("name", value)) => name = percent_decode(value).map_err(|e| format!("its name: {e}"))?,
                Some(_) => {}
                None if parameter.eq_ignore_ascii_case("base64") => {
                    return Err("base64 data: URIs are not read; percent-encode the text".to_owned());
                }
                None => return Err(format!("its parameter `{parameter}` is not attribute=value")),
            }
        }
        let text = percent_decode(data)?;
        Ok((name, text))
    })())
}

#[cfg(test)]
mod data_tests {
    use super::*;

    #[test]
    fn a_text_survives_the_round_trip_with_its_name() {
        let text = "# a scene\n[pose]\nposition_m = [0.0, -1.5e-3, 30]  # é, 100 %, \"quoted\", a,b\n";
        let uri = data_uri("application/toml", "lt50m C.toml", text);
        assert!(uri.starts_with("data:application/toml;name=lt50m%20C.toml,"), "{uri}");
        let data = uri.split_once(',').unwrap().1;
        assert!(!data.contains([' ', '\n', '"', '#', ',']), "{uri}");
        assert_eq!(parse_data_uri(&uri).unwrap().unwrap(), ("lt50m C.toml".to_owned(), text.to_owned()));
    }

    #[test]
    fn the_rfc_example_reads_and_other_forms_are_refused_by_name() {
        assert_eq!(parse_data_uri("data:,A%20brief%20note").unwrap().unwrap(), (String::new(), "A brief note".into()));
        assert!(parse_data_uri("lt50m_C.toml").is_none());
        let e = parse_data_uri("data:text/plain;base64,SGVsbG8=").unwrap().unwrap_err();
        assert!(e.contains("base64"), "{e}");
        assert!(parse_data_uri("data:text/plain").unwrap().unwrap_err().contains("comma"));
        assert!(parse_data_uri("data:,%zz").unwrap().unwrap_err().contains("percent"));
    }
}
