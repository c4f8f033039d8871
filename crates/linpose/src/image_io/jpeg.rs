//! What linpose checks in a JPEG's markers before decoding it: the colour components of its
//! frame (CMYK is refused) and the end-of-image marker (a truncated file is refused, where the
//! decoder would fill the missing rows in and say nothing).

/// A JPEG's frame header (SOFn): sample precision in bits and the number of colour components.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Frame {
    pub precision: u8,
    pub components: u8,
}

/// What the markers of a JPEG say: its frame header, if one comes before the first scan, and
/// whether an end-of-image marker follows the first scan.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Markers {
    pub frame: Option<Frame>,
    pub ends: bool,
}

/// Walks the marker segments of `bytes` (a JPEG: SOI first) up to the first start of scan
/// (SOS), then looks for the end-of-image marker (EOI) after it. Never reads past the end: a
/// segment cut short just ends the walk.
pub(super) fn markers(bytes: &[u8]) -> Markers {
    let mut frame = None;
    let mut i = 2; // after SOI
    loop {
        // A marker: 0xFF, any number of fill bytes 0xFF, then its code.
        if bytes.get(i) != Some(&0xFF) {
            return Markers { frame, ends: false };
        }
        while bytes.get(i) == Some(&0xFF) {
            i += 1;
        }
        let Some(&code) = bytes.get(i) else { return Markers { frame, ends: false } };
        i += 1;
        match code {
            // Markers without a segment: TEM, RSTn, SOI.
            0x01 | 0xD0..=0xD8 => continue,
            0xD9 => return Markers { frame, ends: false },
            _ => {}
        }
        let Some(len) = bytes.get(i..i + 2).map(|b| u16::from_be_bytes([b[0], b[1]]) as usize) else {
            return Markers { frame, ends: false };
        };
        // SOF0..SOF15, except DHT (C4), JPG (C8) and DAC (CC).
        if matches!(code, 0xC0..=0xCF) && !matches!(code, 0xC4 | 0xC8 | 0xCC) && frame.is_none() {
            if let Some(s) = bytes.get(i + 2..i + 8) {
                frame = Some(Frame { precision: s[0], components: s[5] });
            }
        }
        if code == 0xDA {
            // The entropy-coded data escapes 0xFF as FF 00 and has only RSTn markers inside, so
            // the first FF D9 after the scan header is an end-of-image marker (or, in a
            // progressive file, one after its last scan).
            let rest = bytes.get(i + len..).unwrap_or(&[]);
            return Markers { frame, ends: rest.windows(2).any(|w| w == [0xFF, 0xD9]) };
        }
        if len < 2 {
            return Markers { frame, ends: false };
        }
        i += len;
    }
}
