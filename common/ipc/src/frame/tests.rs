//! Layout, round trip and malformed-payload tests of the frame message.

use gfs_core::ImageView;

use super::*;

/// An 8-byte aligned byte buffer, as a topic payload is.
fn aligned(len: usize) -> Vec<u64> {
    vec![0u64; len.div_ceil(8)]
}

fn small_frame(w: usize, h: usize, with_rgb: bool) -> (FrameLayout, Vec<u64>) {
    let layout = FrameLayout::new(w, h, with_rgb).unwrap();
    let mut buf = aligned(layout.byte_len());
    let bytes: &mut [u8] = bytemuck::cast_slice_mut(&mut buf);
    let planes = FrameViewMut::new(&layout, &mut bytes[..layout.byte_len()]).unwrap();
    for (i, p) in planes.gray.iter_mut().enumerate() {
        *p = i as u8;
    }
    for (i, p) in planes.depth.iter_mut().enumerate() {
        *p = i as f32 * 0.5;
    }
    if let Some(rgb) = planes.rgb {
        for (i, p) in rgb.iter_mut().enumerate() {
            *p = [i as u8, 2, 3];
        }
    }
    (layout, buf)
}

#[test]
fn vga_layout_offsets() {
    let l = FrameLayout::new(640, 480, true).unwrap();
    assert_eq!(l.gray().offset, 128);
    assert_eq!(l.depth().offset, 128 + 307_200);
    assert_eq!(l.rgb().unwrap().offset, 128 + 307_200 + 1_228_800);
    assert_eq!(l.byte_len(), 2_457_728);
    assert_eq!(
        FrameLayout::new(640, 480, false).unwrap().byte_len(),
        1_536_128
    );
    assert!(FrameLayout::new(usize::MAX / 2, 3, true).is_err());
}

#[test]
fn written_frame_parses_back() {
    let (layout, buf) = small_frame(5, 3, true);
    let bytes: &[u8] = bytemuck::cast_slice(&buf);
    let f = FrameView::parse(&bytes[..layout.byte_len()]).unwrap();
    assert_eq!(f.gray().row(2), &[10, 11, 12, 13, 14]);
    assert_eq!(f.depth().get(4, 2), Some(7.0));
    assert_eq!(f.rgb().unwrap().get(1, 1), Some([6, 2, 3]));
    let (layout, buf) = small_frame(4, 4, false);
    let bytes: &[u8] = bytemuck::cast_slice(&buf);
    assert!(
        FrameView::parse(&bytes[..layout.byte_len()])
            .unwrap()
            .rgb()
            .is_none()
    );
    // Empty images are valid frames.
    let (layout, buf) = small_frame(0, 0, true);
    let bytes: &[u8] = bytemuck::cast_slice(&buf);
    assert!(
        FrameView::parse(&bytes[..layout.byte_len()])
            .unwrap()
            .gray()
            .is_empty()
    );
}

#[test]
fn every_truncation_is_an_error() {
    let (layout, buf) = small_frame(5, 3, true);
    let bytes: &[u8] = bytemuck::cast_slice(&buf);
    for cut in 0..layout.byte_len() {
        assert!(
            matches!(
                FrameView::parse(&bytes[..cut]),
                Err(FrameError::Truncated { .. })
            ),
            "cut {cut}"
        );
    }
}

#[test]
fn corrupt_headers_are_errors_not_panics() {
    let (layout, buf) = small_frame(5, 3, true);
    let good: &[u8] = bytemuck::cast_slice(&buf);
    let good = &good[..layout.byte_len()];
    let mut magic = buf.clone();
    magic[0] ^= 1;
    let magic: &[u8] = bytemuck::cast_slice(&magic);
    assert!(matches!(
        FrameView::parse(&magic[..layout.byte_len()]),
        Err(FrameError::BadMagic { .. })
    ));
    // Every header word set to every awkward value: Ok or Err, never a panic.
    for word in 1..FRAME_HEADER_BYTES / 8 {
        for value in [0, 1, 2, 3, 7, 127, 1 << 20, 1 << 40, u64::MAX / 3, u64::MAX] {
            let mut bad = buf.clone();
            bad[word] = value;
            let bytes: &[u8] = bytemuck::cast_slice(&bad);
            let _ = FrameView::parse(&bytes[..good.len()]);
        }
    }
    // Specific corruptions and the error each one gives (words: 1 + 5 * plane + field).
    let parse_with = |word: usize, value: u64| {
        let mut bad = buf.clone();
        bad[word] = value;
        let bytes: &[u8] = bytemuck::cast_slice(&bad);
        FrameView::parse(&bytes[..good.len()]).map(|_| ())
    };
    let bad_plane = |r: Result<(), FrameError>| matches!(r, Err(FrameError::BadPlane { .. }));
    assert!(bad_plane(parse_with(1, 2)), "gray slot with depth format");
    assert!(bad_plane(parse_with(6, 0)), "depth plane missing");
    assert!(
        bad_plane(parse_with(5, 64)),
        "gray offset inside the header"
    );
    assert!(bad_plane(parse_with(2, u64::MAX)), "width overflows");
    let truncated = |r: Result<(), FrameError>| matches!(r, Err(FrameError::Truncated { .. }));
    assert!(
        truncated(parse_with(8, 1 << 20)),
        "depth height past the end"
    );
    assert!(
        truncated(parse_with(15, 1 << 40)),
        "rgb offset past the end"
    );
    assert!(
        matches!(
            parse_with(9, 2),
            Err(FrameError::Image { plane: "depth", .. })
        ),
        "stride below width"
    );
    assert_eq!(
        parse_with(11, 0),
        Ok(()),
        "rgb plane dropped is still a frame"
    );
    // A payload that starts off the 8-byte grid cannot be read as f32 in place.
    let mut shifted = aligned(good.len() + 8);
    let sbytes: &mut [u8] = bytemuck::cast_slice_mut(&mut shifted);
    sbytes[1..=good.len()].copy_from_slice(good);
    assert!(matches!(
        FrameView::parse(&sbytes[1..=good.len()]),
        Err(FrameError::Misaligned { plane: "depth", .. })
    ));
}

#[test]
fn images_of_different_sizes_are_refused() {
    let gray = vec![0u8; 12];
    let depth = vec![0f32; 12];
    let images = FrameImages {
        gray: ImageView::new(4, 3, 4, &gray).unwrap(),
        depth: ImageView::new(3, 4, 3, &depth).unwrap(),
        rgb: None,
    };
    assert!(matches!(
        images.layout(),
        Err(FrameError::SizeMismatch { .. })
    ));
}
