//! Frame patterns and ranges from arbitrary strings: errors, never panics; a parsed
//! pattern turns frame numbers into paths and finds its own frame back in them.
#![no_main]

use activeskin::sequence::{parse_range, FramePattern};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let _ = parse_range(text);
    if let Ok(pattern) = FramePattern::parse(text) {
        for frame in [0i64, 1, 7, 42, 1001, -3, 123_456_789, i64::MAX, i64::MIN] {
            let path = pattern.path(frame);
            let path = path.to_str().expect("a pattern from a str makes str paths");
            assert_eq!(pattern.frame_of(path), Some(frame), "{text:?} {path:?}");
        }
    }
});
