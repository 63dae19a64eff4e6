//! Frame-numbered file patterns, as DCCs write them: `name.####.vdb` (Houdini, zero-padded
//! to the number of `#`), `name.%04d.vdb` (printf), `name.$F4.vdb` and `name.$F.vdb`
//! (Houdini variables, `$F` unpadded), `name_{}.vtk` (splashsurf's, unpadded).

use std::path::PathBuf;

/// A pattern that cannot be used.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum PatternError {
    #[error("pattern '{0}' has no frame number (use ####, %04d, $F4, $F or {{}})")]
    NoFrameNumber(String),
    #[error("pattern '{0}' has more than one frame number")]
    SeveralFrameNumbers(String),
    #[error("pattern '{0}' pads frame numbers to more than {MAX_WIDTH} digits")]
    TooWide(String),
    #[error("cannot list the folder of pattern '{pattern}': {reason}")]
    Unreadable { pattern: String, reason: String },
}

/// The widest padding a pattern may ask for: an i64 has 19 digits.
pub const MAX_WIDTH: usize = 20;

/// A file name with one frame-number field, or one file held for every frame.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FramePattern {
    prefix: String,
    suffix: String,
    /// Minimum digits (zero-padded); 1 for an unpadded `$F`; 0 for one held file.
    width: usize,
}

/// The pattern as `prefix####suffix`, one `#` a padded digit (`#` alone: unpadded), as
/// messages name it; a held file as its path.
impl std::fmt::Display for FramePattern {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}{}{}",
            self.prefix,
            "#".repeat(self.width),
            self.suffix
        )
    }
}

impl FramePattern {
    /// One file standing for every frame (a static target).
    pub fn held(path: &str) -> Self {
        FramePattern {
            prefix: path.to_owned(),
            suffix: String::new(),
            width: 0,
        }
    }

    /// Files `prefix`, the frame number padded to `width` digits, `suffix`.
    pub fn numbered(prefix: &str, width: usize, suffix: &str) -> Self {
        FramePattern {
            prefix: prefix.to_owned(),
            suffix: suffix.to_owned(),
            width: width.clamp(1, MAX_WIDTH),
        }
    }

    /// Whether this is one file held for every frame.
    pub fn is_held(&self) -> bool {
        self.width == 0
    }

    pub fn parse(pattern: &str) -> Result<Self, PatternError> {
        let fields = frame_fields(pattern);
        match fields.as_slice() {
            [] => Err(PatternError::NoFrameNumber(pattern.to_owned())),
            // Unparsable digits (too many for usize) count as too wide, not as unpadded.
            [(_, _, None)] => Err(PatternError::TooWide(pattern.to_owned())),
            [(_, _, Some(width))] if *width > MAX_WIDTH => {
                Err(PatternError::TooWide(pattern.to_owned()))
            }
            [(start, end, Some(width))] => Ok(FramePattern {
                prefix: pattern[..*start].to_owned(),
                suffix: pattern[*end..].to_owned(),
                width: *width,
            }),
            _ => Err(PatternError::SeveralFrameNumbers(pattern.to_owned())),
        }
    }

    /// The file of one frame. Negative frames keep their sign before the padding.
    pub fn path(&self, frame: i64) -> PathBuf {
        if self.is_held() {
            return PathBuf::from(&self.prefix);
        }
        let width = self.width;
        let number = if frame < 0 {
            // unsigned_abs: -i64::MIN does not fit in an i64 (found by cargo fuzz).
            format!("-{:0width$}", frame.unsigned_abs())
        } else {
            format!("{frame:0width$}")
        };
        PathBuf::from(format!("{}{number}{}", self.prefix, self.suffix))
    }

    /// The frame a file name stands for, if it matches the pattern.
    pub fn frame_of(&self, path: &str) -> Option<i64> {
        if self.is_held() {
            return None;
        }
        let digits = path
            .strip_prefix(&self.prefix)?
            .strip_suffix(&self.suffix)?;
        let unsigned = digits.strip_prefix('-').unwrap_or(digits);
        if unsigned.is_empty() || !unsigned.bytes().all(|b| b.is_ascii_digit()) {
            return None;
        }
        let frame: i64 = digits.parse().ok()?;
        // Only the spelling this pattern writes: `7` does not match `####`.
        (self.path(frame).to_str() == Some(path)).then_some(frame)
    }

    /// Every frame whose file exists, in order (none when the folder does not exist).
    pub fn existing_frames(&self) -> Result<Vec<i64>, PatternError> {
        let pattern = self.path(0);
        let folder = match pattern.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let unreadable = |e: std::io::Error| PatternError::Unreadable {
            pattern: self.to_string(),
            reason: e.to_string(),
        };
        let mut frames = Vec::new();
        let entries = match std::fs::read_dir(&folder) {
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(frames),
            listed => listed.map_err(unreadable)?,
        };
        for entry in entries {
            let entry = entry.map_err(unreadable)?;
            let joined = match pattern.parent() {
                Some(p) if !p.as_os_str().is_empty() => p.join(entry.file_name()),
                _ => PathBuf::from(entry.file_name()),
            };
            if let Some(frame) = joined.to_str().and_then(|p| self.frame_of(p)) {
                if entry.path().is_file() {
                    frames.push(frame);
                }
            }
        }
        frames.sort_unstable();
        Ok(frames)
    }

    /// The folder the frames go to.
    pub fn folder(&self) -> PathBuf {
        match self.path(0).parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        }
    }
}

/// Byte ranges and widths of the frame fields of a pattern (`None`: digits that do not
/// fit a usize).
fn frame_fields(pattern: &str) -> Vec<(usize, usize, Option<usize>)> {
    let bytes = pattern.as_bytes();
    let mut fields = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        let digits_from = |j: usize| {
            let n = bytes[j..].iter().take_while(|b| b.is_ascii_digit()).count();
            (n, pattern[j..j + n].parse::<usize>().ok())
        };
        match bytes[i] {
            b'#' => {
                let n = bytes[i..].iter().take_while(|&&b| b == b'#').count();
                fields.push((i, i + n, Some(n)));
                i += n;
            }
            b'%' => {
                // %d, %4d, %04d
                let (n, width) = digits_from(i + 1);
                if bytes.get(i + 1 + n) == Some(&b'd') {
                    let width = if n == 0 {
                        Some(1)
                    } else {
                        width.map(|w| w.max(1))
                    };
                    fields.push((i, i + n + 2, width));
                    i += n + 2;
                } else {
                    i += 1;
                }
            }
            // splashsurf's `{}`: unpadded, as SPlisHSPlasH numbers its exports.
            b'{' if bytes.get(i + 1) == Some(&b'}') => {
                fields.push((i, i + 2, Some(1)));
                i += 2;
            }
            b'$' if bytes.get(i + 1) == Some(&b'F') => {
                let (n, width) = digits_from(i + 2);
                let width = if n == 0 {
                    Some(1)
                } else {
                    width.map(|w| w.max(1))
                };
                fields.push((i, i + 2 + n, width));
                i += 2 + n;
            }
            _ => i += 1,
        }
    }
    fields
}

/// `A-B` (inclusive), or a single frame `A`.
pub fn parse_range(spec: &str) -> Option<(i64, i64)> {
    let spec = spec.trim();
    // A leading '-' is a negative first frame, not the separator. (Search from the second
    // character, not byte: `--frames` may hold anything.)
    let skip = spec.chars().next().map_or(0, char::len_utf8);
    let split = spec[skip..].find('-').map(|i| i + skip);
    let (a, b) = match split {
        Some(i) => (
            spec[..i].trim().parse().ok()?,
            spec[i + 1..].trim().parse().ok()?,
        ),
        None => {
            let a = spec.parse().ok()?;
            (a, a)
        }
    };
    (a <= b).then_some((a, b))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn absurd_padding_is_an_error() {
        // Found by cargo fuzz: a width past what format! accepts panicked.
        for spec in [
            "x.%99999999999d.vdb",
            "x.%999999999999999999999999d",
            "x.$F21",
        ] {
            assert_eq!(
                FramePattern::parse(spec),
                Err(PatternError::TooWide(spec.into())),
                "{spec}"
            );
        }
        assert!(FramePattern::parse(&format!("x.{}.vdb", "#".repeat(70_000))).is_err());
        assert!(FramePattern::parse("x.$F20").is_ok());
    }

    #[test]
    fn extreme_frames_round_trip() {
        // Found by cargo fuzz: i64::MIN was written with two minus signs.
        let pattern = FramePattern::parse("#\u{b}$:").unwrap();
        for frame in [i64::MIN, i64::MIN + 1, -1, 0, i64::MAX] {
            let path = pattern.path(frame);
            assert_eq!(pattern.frame_of(path.to_str().unwrap()), Some(frame));
        }
    }

    #[test]
    fn every_spelling_formats_like_its_dcc() {
        let cases = [
            ("out/skin.####.vdb", 7, "out/skin.0007.vdb"),
            ("skin.#.vdb", 12, "skin.12.vdb"),
            ("skin.%04d.vdb", 7, "skin.0007.vdb"),
            ("skin.%d.vdb", 7, "skin.7.vdb"),
            ("skin.$F4.vdb", 7, "skin.0007.vdb"),
            ("skin.$F.vdb", 7, "skin.7.vdb"),
            ("ParticleData_Fluid_{}.vtk", 12, "ParticleData_Fluid_12.vtk"),
            ("skin_$F3_v2.obj", 12345, "skin_12345_v2.obj"),
            ("skin.####.vdb", -3, "skin.-0003.vdb"),
        ];
        for (pattern, frame, expected) in cases {
            let p = FramePattern::parse(pattern).unwrap();
            assert_eq!(p.path(frame), PathBuf::from(expected), "{pattern}");
            assert_eq!(p.frame_of(expected), Some(frame), "{pattern}");
        }
    }

    #[test]
    fn only_the_written_spelling_matches() {
        let p = FramePattern::parse("a.####.vdb").unwrap();
        assert_eq!(p.frame_of("a.7.vdb"), None);
        assert_eq!(p.frame_of("a.00x7.vdb"), None);
        assert_eq!(p.frame_of("b.0007.vdb"), None);
        assert_eq!(p.frame_of("a.0007.vdb.tmp"), None);
    }

    #[test]
    fn bad_patterns_are_named() {
        assert_eq!(
            FramePattern::parse("skin.vdb"),
            Err(PatternError::NoFrameNumber("skin.vdb".into()))
        );
        assert!(matches!(
            FramePattern::parse("a.####.$F.vdb"),
            Err(PatternError::SeveralFrameNumbers(_))
        ));
        // A lone '%' or '$' is text.
        assert_eq!(
            FramePattern::parse("100%_$x.##.vdb").unwrap().path(3),
            PathBuf::from("100%_$x.03.vdb")
        );
    }

    #[test]
    fn ranges() {
        assert_eq!(parse_range("1-96"), Some((1, 96)));
        assert_eq!(parse_range("5"), Some((5, 5)));
        assert_eq!(parse_range("-5-3"), Some((-5, 3)));
        assert_eq!(parse_range("9-3"), None);
        assert_eq!(parse_range("a-b"), None);
        assert_eq!(parse_range(""), None);
        assert_eq!(parse_range("-5--2"), Some((-5, -2)));
        // Found by cargo fuzz: a multi-byte first character was sliced through.
        assert_eq!(parse_range("\u{532}\u{f}"), None);
        assert_eq!(parse_range("Բ-1"), None);
    }

    #[test]
    fn existing_frames_are_found_in_order() {
        let dir = tempfile::tempdir().unwrap();
        for name in [
            "t.0003.vdb",
            "t.0001.vdb",
            "t.0002.vdb.tmp",
            "t.12.vdb",
            "u.0002.vdb",
        ] {
            std::fs::write(dir.path().join(name), b"").unwrap();
        }
        let pattern = format!("{}/t.####.vdb", dir.path().display());
        let p = FramePattern::parse(&pattern).unwrap();
        assert_eq!(p.existing_frames().unwrap(), vec![1, 3]);
    }
}
