use super::*;
use crate::msg::Time;
use ::image::codecs::jpeg::JpegEncoder;
use ::image::codecs::png::PngEncoder;
use ::image::{ExtendedColorType, ImageEncoder};

const TOPIC: &str = "/camera/color/image_raw/compressed";

fn compressed(format: &str, data: Vec<u8>) -> TransportImage {
    TransportImage::Compressed(CompressedImage {
        header: Header {
            stamp: Time {
                sec: 1305031102,
                nanosec: 175_304_000,
            },
            frame_id: "cam".to_owned(),
        },
        format: format.to_owned(),
        data,
    })
}

fn png(pixels: &[u8], w: u32, h: u32, colour: ExtendedColorType) -> Vec<u8> {
    let mut out = Vec::new();
    PngEncoder::new(&mut out)
        .write_image(pixels, w, h, colour)
        .unwrap();
    out
}

/// A 16x12 RGB gradient: smooth, so that JPEG keeps it within a few levels.
fn gradient() -> Vec<u8> {
    (0..12u32)
        .flat_map(|y| (0..16u32).flat_map(move |x| [(x * 12) as u8, (y * 16) as u8, 128]))
        .collect()
}

/// A 16UC1 PNG of `values` (one row), as compressedDepth writes it.
fn depth_png(values: &[u16]) -> Vec<u8> {
    let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_ne_bytes()).collect();
    png(&bytes, values.len() as u32, 1, ExtendedColorType::L16)
}

fn header(format: i32, a: f32, b: f32) -> Vec<u8> {
    [format.to_le_bytes(), a.to_le_bytes(), b.to_le_bytes()].concat()
}

#[test]
fn png_colour_decodes_to_the_same_pixels_and_jpeg_within_a_few_levels() {
    let rgb = gradient();
    let mut decoder = TransportDecoder::new();
    let message = compressed(
        "rgb8; png compressed bgr8",
        png(&rgb, 16, 12, ExtendedColorType::Rgb8),
    );
    let image = decoder.colour(&message, TOPIC).unwrap();
    assert_eq!(
        (
            image.encoding.as_str(),
            image.width,
            image.height,
            image.step
        ),
        ("rgb8", 16, 12, 48)
    );
    assert_eq!(image.data, rgb);
    assert_eq!(image.header.stamp.nanosec, 175_304_000);

    let mut jpeg = Vec::new();
    JpegEncoder::new_with_quality(&mut jpeg, 95)
        .write_image(&rgb, 16, 12, ExtendedColorType::Rgb8)
        .unwrap();
    let message = compressed("bgr8; jpeg compressed bgr8", jpeg);
    let image = decoder.colour(&message, TOPIC).unwrap();
    assert_eq!((image.encoding.as_str(), image.step), ("rgb8", 48));
    let worst = image
        .data
        .iter()
        .zip(&rgb)
        .map(|(a, b)| a.abs_diff(*b))
        .max()
        .unwrap();
    assert!(worst <= 8, "JPEG q95 off by {worst} levels");

    let gray: Vec<u8> = (0..48).map(|v| v * 5).collect();
    let message = compressed("png", png(&gray, 8, 6, ExtendedColorType::L8));
    let image = decoder.colour(&message, TOPIC).unwrap();
    assert_eq!((image.encoding.as_str(), &image.data), ("mono8", &gray));
}

#[test]
fn compressed_depth_16uc1_is_the_millimetres_and_32fc1_the_inverse_depth() {
    let mm = [0u16, 1, 800, 4095, 65535];
    let mut data = header(0, 0.0, 0.0);
    data.extend(depth_png(&mm));
    let mut decoder = TransportDecoder::new();
    let message = compressed("16UC1; compressedDepth png", data);
    let image = decoder.depth(&message, "/d/compressedDepth").unwrap();
    assert_eq!(
        (
            image.encoding.as_str(),
            image.width,
            image.height,
            image.step
        ),
        ("16UC1", 5, 1, 10)
    );
    let back: Vec<u16> = image
        .data
        .chunks_exact(2)
        .map(|b| u16::from_ne_bytes([b[0], b[1]]))
        .collect();
    assert_eq!(back, mm);

    // The publisher's defaults: depth_quantization 100, depth_max 10 m.
    let a = 100.0f32 * 101.0;
    let b = 1.0 - a / 10.0;
    let metres = [0.5f32, 1.0, 2.0, 9.0, 12.0];
    let quantised: Vec<u16> = metres
        .iter()
        .map(|&d| if d < 10.0 { (a / d + b) as u16 } else { 0 })
        .collect();
    let mut data = header(0, a, b);
    data.extend(depth_png(&quantised));
    let message = compressed("32FC1; compressedDepth png", data);
    let image = decoder.depth(&message, "/d/compressedDepth").unwrap();
    assert_eq!(
        (
            image.encoding.as_str(),
            image.width,
            image.height,
            image.step
        ),
        ("32FC1", 5, 1, 20)
    );
    let back: Vec<f32> = image
        .data
        .chunks_exact(4)
        .map(|b| f32::from_ne_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    for (d, got) in metres[..4].iter().zip(&back) {
        // One quantisation step of inverse depth is d^2 / A metres.
        assert!((got - d).abs() <= d * d / a, "{d} m read as {got} m");
    }
    assert!(back[4].is_nan(), "beyond depth_max: no return");
}

#[test]
fn bad_compressed_images_are_errors_naming_topic_stamp_and_cause() {
    let mut decoder = TransportDecoder::new();
    let reason = |decoder: &mut TransportDecoder, message: &TransportImage, depth: bool| {
        let e = if depth {
            decoder.depth(message, "/d/compressedDepth").unwrap_err()
        } else {
            decoder.colour(message, TOPIC).unwrap_err()
        };
        let text = e.to_string();
        assert!(text.contains("1305031102.175304 s"), "{text}");
        assert!(
            text.starts_with(if depth { "/d/compressedDepth" } else { TOPIC }),
            "{text}"
        );
        e.reason
    };
    let whole = png(&gradient(), 16, 12, ExtendedColorType::Rgb8);
    let cut = compressed(
        "rgb8; png compressed bgr8",
        whole[..whole.len() / 2].to_vec(),
    );
    assert!(!reason(&mut decoder, &cut, false).is_empty());
    let swapped = compressed("rgb8; jpeg compressed bgr8", whole.clone());
    assert!(reason(&mut decoder, &swapped, false).contains("JPEG"));
    let unknown = compressed("rgb8; tiff compressed bgr8", whole.clone());
    assert!(reason(&mut decoder, &unknown, false).contains("neither jpeg nor png"));

    let depth = depth_png(&[1000, 2000]);
    let mut wrong = header(7, 0.0, 0.0);
    wrong.extend(&depth);
    let wrong = compressed("16UC1; compressedDepth png", wrong);
    assert!(reason(&mut decoder, &wrong, true).contains("INV_DEPTH"));
    let headless = compressed("16UC1; compressedDepth png", depth.clone());
    assert!(reason(&mut decoder, &headless, true).contains("header format"));
    let mut bad_params = header(0, 0.0, f32::NAN);
    bad_params.extend(&depth);
    let bad_params = compressed("32FC1; compressedDepth png", bad_params);
    assert!(reason(&mut decoder, &bad_params, true).contains("quantisation"));
    let mut cut = header(0, 0.0, 0.0);
    cut.extend(&depth[..depth.len() - 20]);
    let cut = compressed("16UC1; compressedDepth png", cut);
    assert!(!reason(&mut decoder, &cut, true).is_empty());
    let rvl = compressed("16UC1; compressedDepth rvl", header(0, 0.0, 0.0));
    assert!(reason(&mut decoder, &rvl, true).contains("compressedDepth png"));
    let colour = compressed("rgb8; png compressed bgr8", whole);
    assert!(reason(&mut decoder, &colour, true).contains("16UC1"));
}
