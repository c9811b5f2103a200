use super::*;
use crate::msg::{Header, Time};
use gfs_core::camera::{Distortion, PinholeCamera};

fn camera(w: usize, h: usize) -> Camera {
    Camera {
        pinhole: PinholeCamera::new(50.0, 50.0, w as f64 / 2.0, h as f64 / 2.0, w, h),
        distortion: Distortion::default(),
    }
}

fn image(encoding: &str, w: u32, h: u32, bpp: u32, data: Vec<u8>) -> Image {
    Image {
        header: Header {
            stamp: Time {
                sec: 12,
                nanosec: 500_000_000,
            },
            frame_id: "camera_color_optical_frame".to_owned(),
        },
        height: h,
        width: w,
        encoding: encoding.to_owned(),
        is_bigendian: 0,
        step: w * bpp,
        data,
    }
}

fn colour(encoding: &str, px: [u8; 4], bpp: u32) -> Image {
    let data = (0..4 * 2)
        .flat_map(|_| px[..bpp as usize].to_vec())
        .collect();
    image(encoding, 4, 2, bpp, data)
}

fn depth_mm(values: [u16; 8]) -> Image {
    image(
        "16UC1",
        4,
        2,
        2,
        values.iter().flat_map(|v| v.to_le_bytes()).collect(),
    )
}

fn convert(c: &Image, d: &Image) -> Result<(Vec<u8>, Vec<f32>), ImageError> {
    let mut conv = FrameConverter::new(&camera(4, 2), &DepthConfig::default());
    let (mut gray, mut depth) = (vec![0u8; 8], vec![0f32; 8]);
    conv.convert(
        Received {
            image: c,
            topic: "/c",
        },
        Received {
            image: d,
            topic: "/d",
        },
        &mut gray,
        &mut depth,
    )?;
    Ok((gray, depth))
}

#[test]
fn every_colour_encoding_gives_the_bt601_gray_of_its_rgb() {
    let d = depth_mm([1000; 8]);
    let want = gray_bt601([200, 100, 50]);
    for (enc, px, bpp) in [
        ("rgb8", [200, 100, 50, 0], 3),
        ("rgba8", [200, 100, 50, 255], 4),
        ("bgr8", [50, 100, 200, 0], 3),
        ("bgra8", [50, 100, 200, 255], 4),
    ] {
        let (gray, _) = convert(&colour(enc, px, bpp), &d).unwrap();
        assert_eq!(gray, vec![want; 8], "{enc}");
    }
    let (gray, _) = convert(&colour("mono8", [77, 0, 0, 0], 1), &d).unwrap();
    assert_eq!(gray, vec![77; 8]);
}

#[test]
fn depth_is_metres_per_rep_118_with_holes_and_range() {
    let c = colour("rgb8", [1, 2, 3, 0], 3);
    let (_, m) = convert(&c, &depth_mm([1500, 0, 65535, 50, 9999, 10001, 2000, 1])).unwrap();
    assert_eq!(m, [1.5, 0.0, 0.0, 0.0, 9.999, 0.0, 2.0, 0.0]);
    let floats = [2.25f32, f32::NAN, 0.0, -1.0, 0.05, 11.0, 3.5, 0.1];
    let d = image(
        "32FC1",
        4,
        2,
        4,
        floats.iter().flat_map(|v| v.to_le_bytes()).collect(),
    );
    let (_, m) = convert(&c, &d).unwrap();
    assert_eq!(m, [2.25, 0.0, 0.0, 0.0, 0.0, 0.0, 3.5, 0.1]);
    let mut big = depth_mm([0; 8]);
    big.is_bigendian = 1;
    big.data = [1234u16; 8].iter().flat_map(|v| v.to_be_bytes()).collect();
    assert_eq!(convert(&c, &big).unwrap().1, [1.234; 8]);
}

#[test]
fn rows_with_padding_are_read_by_step() {
    let mut c = colour("mono8", [9, 0, 0, 0], 1);
    c.step = 6;
    c.data = vec![9, 9, 9, 9, 0, 0, 8, 8, 8, 8, 0, 0];
    let (gray, _) = convert(&c, &depth_mm([1000; 8])).unwrap();
    assert_eq!(gray, [9, 9, 9, 9, 8, 8, 8, 8]);
}

#[test]
fn bad_images_are_errors_naming_topic_and_stamp() {
    let d = depth_mm([1000; 8]);
    let e = convert(&colour("yuv422", [0; 4], 2), &d).unwrap_err();
    assert_eq!(e.topic, "/c");
    assert_eq!(e.stamp.nanos(), 12_500_000_000);
    assert!(
        e.to_string()
            .starts_with("/c at 12.500000 s: colour encoding \"yuv422\"")
    );
    let small = image("16UC1", 2, 2, 2, vec![0; 8]);
    let e = convert(&colour("rgb8", [0; 4], 3), &small).unwrap_err();
    assert_eq!(e.topic, "/d");
    assert!(e.reason.contains("2x2 16UC1 image, expected 4x2"), "{e}");
    let mut short = colour("rgb8", [0; 4], 3);
    short.data.truncate(20);
    assert!(
        convert(&short, &d)
            .unwrap_err()
            .reason
            .contains("20 bytes of data")
    );
    let mut step = colour("rgb8", [0; 4], 3);
    step.step = 8;
    assert!(convert(&step, &d).unwrap_err().reason.contains("step 8"));
    let e = convert(
        &colour("rgb8", [0; 4], 3),
        &image("8UC3", 4, 2, 3, vec![0; 24]),
    )
    .unwrap_err();
    assert!(e.reason.contains("REP 118"), "{e}");
}
