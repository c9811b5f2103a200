//! Bags as robots record them and as a hostile file looks: zstd / lz4 chunks, image
//! topics compressed by `image_transport`, and crafted bytes (a record length of 2^40,
//! bit flips in the summary and data, a corrupt zstd chunk, a file cut short, another
//! schema on the image topic): the same frames, or an error naming the file and the
//! offset, never a panic or an abort.

use gfs_ros2::Transport;
use gfs_ros2::bag::{BagError, BagReader, BagTopics, BagWriter, Compression, scan};
use gfs_ros2::msg::{CameraInfo, CompressedImage, Header, Image, StringMsg, Time};
use gfs_ros2::schema;
use gfs_ros2::transport::{TransportDecoder, TransportImage};
use image::codecs::png::PngEncoder;
use image::{ExtendedColorType, ImageEncoder};
use std::path::{Path, PathBuf};

const W: u32 = 32;
const H: u32 = 24;

fn topics(transport: Transport) -> BagTopics {
    BagTopics {
        colour: "/c".to_owned(),
        depth: "/d".to_owned(),
        camera_info: "/i".to_owned(),
        transport,
        imu: None,
    }
}

fn dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("gfs-ros2-input-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn header(k: u32) -> Header {
    Header {
        stamp: Time {
            sec: 1_700_000_000,
            nanosec: k * 33_333_333 + 7,
        },
        frame_id: "cam".to_owned(),
    }
}

/// Frame k's colour (a texture that changes with k) and depth in millimetres.
fn pixels(k: u32) -> (Vec<u8>, Vec<u16>) {
    let rgb = (0..W * H * 3)
        .map(|i| ((i * 7 + k * 13) % 251) as u8)
        .collect();
    let mm = (0..W * H).map(|i| (500 + i * 3 + k) as u16).collect();
    (rgb, mm)
}

fn png(bytes: &[u8], colour: ExtendedColorType) -> Vec<u8> {
    let mut out = Vec::new();
    PngEncoder::new(&mut out)
        .write_image(bytes, W, H, colour)
        .unwrap();
    out
}

/// Raw and/or compressed (png colour, compressedDepth png) frames with camera info.
fn write(path: &Path, frames: u32, compression: Compression, raw: bool, compressed: bool) {
    let mut w = BagWriter::create(path, compression).unwrap();
    for k in 0..frames {
        let t = u64::try_from(header(k).stamp.nanos()).unwrap();
        let (rgb, mm) = pixels(k);
        let info = CameraInfo {
            header: header(k),
            width: W,
            height: H,
            ..CameraInfo::default()
        };
        w.write("/i", &schema::CAMERA_INFO, t, &info).unwrap();
        w.write("/other", &schema::STRING, t, &StringMsg::default())
            .unwrap();
        if raw {
            let depth: Vec<u8> = mm.iter().flat_map(|v| v.to_le_bytes()).collect();
            let image = |encoding: &str, step, data| Image {
                header: header(k),
                height: H,
                width: W,
                encoding: encoding.to_owned(),
                is_bigendian: 0,
                step,
                data,
            };
            w.write("/c", &schema::IMAGE, t, &image("rgb8", 3 * W, rgb.clone()))
                .unwrap();
            w.write("/d", &schema::IMAGE, t, &image("16UC1", 2 * W, depth))
                .unwrap();
        }
        if compressed {
            let colour = CompressedImage {
                header: header(k),
                format: "rgb8; png compressed bgr8".to_owned(),
                data: png(&rgb, ExtendedColorType::Rgb8),
            };
            let native: Vec<u8> = mm.iter().flat_map(|v| v.to_ne_bytes()).collect();
            let mut data = vec![0u8; 12];
            data.extend(png(&native, ExtendedColorType::L16));
            let depth = CompressedImage {
                header: header(k),
                format: "16UC1; compressedDepth png".to_owned(),
                data,
            };
            w.write("/c/compressed", &schema::COMPRESSED_IMAGE, t, &colour)
                .unwrap();
            w.write("/d/compressedDepth", &schema::COMPRESSED_IMAGE, t, &depth)
                .unwrap();
        }
    }
    w.finish().unwrap();
}

/// Every frame's colour and depth bytes, decoded.
fn frames(path: &Path, transport: Transport) -> Vec<(Vec<u8>, Vec<u8>)> {
    let mut reader = BagReader::open(path, &topics(transport), 0.005).unwrap();
    let (c, d) = reader.image_topics();
    let (c, d) = (c.to_owned(), d.to_owned());
    let mut decoders = (TransportDecoder::new(), TransportDecoder::new());
    let mut out = Vec::new();
    while let Some(frame) = reader.next_frame().unwrap() {
        let colour = decoders.0.colour(&frame.colour, &c).unwrap().data.clone();
        let depth = decoders.1.depth(&frame.depth, &d).unwrap();
        assert_eq!(
            (depth.encoding.as_str(), depth.width, depth.height),
            ("16UC1", W, H)
        );
        let mm: Vec<u8> = depth
            .data
            .chunks_exact(2)
            .flat_map(|b| u16::from_ne_bytes([b[0], b[1]]).to_le_bytes())
            .collect();
        out.push((colour, mm));
    }
    out
}

fn expected(n: u32) -> Vec<(Vec<u8>, Vec<u8>)> {
    (0..n)
        .map(|k| {
            let (rgb, mm) = pixels(k);
            (rgb, mm.iter().flat_map(|v| v.to_le_bytes()).collect())
        })
        .collect()
}

#[test]
fn zstd_lz4_and_uncompressed_chunks_read_to_the_same_frames() {
    let d = dir("chunks");
    let mut sizes = Vec::new();
    for (name, compression) in [
        ("none", Compression::None),
        ("lz4", Compression::Lz4),
        ("zstd", Compression::Zstd),
    ] {
        let path = d.join(format!("{name}.mcap"));
        write(&path, 6, compression, true, false);
        let bytes = std::fs::read(&path).unwrap();
        if compression != Compression::None {
            assert!(bytes.windows(name.len()).any(|w| w == name.as_bytes()));
        }
        sizes.push(bytes.len());
        assert_eq!(frames(&path, Transport::Raw), expected(6), "{name}");
        assert!(!d.join(format!("{name}.mcap.partial")).exists());
    }
    assert!(sizes[1] < sizes[0] && sizes[2] < sizes[0], "{sizes:?}");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn compressed_image_topics_are_found_and_decode_to_the_raw_frames() {
    let d = dir("transport");
    let only = d.join("compressed.mcap");
    write(&only, 4, Compression::Zstd, false, true);
    let reader = BagReader::open(&only, &topics(Transport::Raw), 0.005).unwrap();
    assert_eq!(
        reader.image_topics(),
        ("/c/compressed", "/d/compressedDepth")
    );
    assert_eq!(frames(&only, Transport::Raw), expected(4));

    let both = d.join("both.mcap");
    write(&both, 4, Compression::Zstd, true, true);
    for (transport, colour) in [
        (Transport::Raw, "/c"),
        (Transport::Compressed, "/c/compressed"),
    ] {
        let reader = BagReader::open(&both, &topics(transport), 0.005).unwrap();
        assert_eq!(reader.image_topics().0, colour);
        assert_eq!(frames(&both, transport), expected(4), "{colour}");
    }
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn a_truncated_png_in_a_bag_is_an_error_naming_topic_and_stamp() {
    let d = dir("cut-png");
    let path = d.join("b.mcap");
    let mut w = BagWriter::create(&path, Compression::Zstd).unwrap();
    let (rgb, _) = pixels(0);
    let whole = png(&rgb, ExtendedColorType::Rgb8);
    let colour = CompressedImage {
        header: header(0),
        format: "png".to_owned(),
        data: whole[..whole.len() - 40].to_vec(),
    };
    w.write("/c/compressed", &schema::COMPRESSED_IMAGE, 1, &colour)
        .unwrap();
    w.finish().unwrap();
    let mut reader = BagReader::open(&path, &topics(Transport::Compressed), 0.005).unwrap();
    // No depth: the read ends with the missing topic, after the colour was read.
    assert!(matches!(
        reader.next_frame(),
        Err(BagError::MissingTopic { .. })
    ));
    let image = TransportImage::Compressed(colour);
    let e = TransportDecoder::new()
        .colour(&image, "/c/compressed")
        .unwrap_err();
    assert_eq!(e.topic, "/c/compressed");
    assert!(
        e.to_string()
            .starts_with("/c/compressed at 1700000000.000000007 s"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&d);
}

fn u64_at(bytes: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap())
}

#[test]
fn a_record_length_of_2_pow_40_or_past_the_end_is_an_error_naming_file_and_offset() {
    let d = dir("length");
    let path = d.join("b.mcap");
    write(&path, 3, Compression::None, true, false);
    let good = std::fs::read(&path).unwrap();
    // The header record follows the 8-byte magic: opcode, then its length.
    for (length, says) in [
        (1u64 << 40, "exceeds limit"),
        (good.len() as u64, "the file has"),
    ] {
        let mut bytes = good.clone();
        bytes[9..17].copy_from_slice(&length.to_le_bytes());
        std::fs::write(&path, &bytes).unwrap();
        match scan(&path, &topics(Transport::Raw), 0.005) {
            Err(e @ BagError::Corrupt { offset: 17, .. }) => {
                let text = e.to_string();
                assert!(text.starts_with(&path.display().to_string()), "{text}");
                assert!(text.contains("at byte 17") && text.contains(says), "{text}");
            }
            other => panic!("expected a corrupt record at byte 17, got {other:?}"),
        }
    }
    let _ = std::fs::remove_dir_all(&d);
}

/// Deterministic bit flips (a 64-bit LCG).
fn flips(seed: u64, count: usize, range: std::ops::Range<usize>) -> Vec<(usize, u8)> {
    let mut state = seed;
    (0..count)
        .map(|_| {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let at = range.start + (state >> 33) as usize % range.len();
            (at, 1u8 << ((state >> 20) % 8))
        })
        .collect()
}

#[test]
fn bit_flips_in_the_summary_and_the_data_are_errors_naming_the_file_never_aborts() {
    let d = dir("flips");
    let path = d.join("b.mcap");
    for compression in [Compression::None, Compression::Zstd] {
        write(&path, 3, compression, true, true);
        let good = std::fs::read(&path).unwrap();
        let footer = good.len() - 8 - 29;
        let summary = u64_at(&good, footer + 9) as usize;
        assert!(summary > 8 && summary < footer);
        let (mut errors, mut trials) = (0, 0);
        for (range, seed) in [(summary..footer + 29, 1), (8..summary, 2)] {
            for (at, bit) in flips(seed, 150, range) {
                let mut bytes = good.clone();
                bytes[at] ^= bit;
                std::fs::write(&path, &bytes).unwrap();
                trials += 1;
                if let Err(e) = scan(&path, &topics(Transport::Raw), 0.005) {
                    errors += 1;
                    let text = e.to_string();
                    assert!(text.starts_with(&path.display().to_string()), "{text}");
                }
            }
        }
        // Flips in payload bytes (pixels) read as other pixels, not as errors.
        assert!(
            errors > 0 && errors <= trials,
            "{compression:?}: {errors} of {trials}"
        );
    }
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn a_corrupt_zstd_chunk_is_an_error_naming_file_offset_and_the_last_message() {
    let d = dir("zstd");
    let path = d.join("b.mcap");
    write(&path, 6, Compression::Zstd, true, false);
    let mut bytes = std::fs::read(&path).unwrap();
    // The first chunk's compressed data: after "zstd" and its 8-byte compressed size.
    let name = bytes.windows(4).position(|w| w == b"zstd").unwrap();
    let start = name + 4 + 8;
    let size = u64_at(&bytes, name + 4) as usize;
    for b in &mut bytes[start + size / 2..start + size / 2 + 64] {
        *b ^= 0x5A;
    }
    std::fs::write(&path, &bytes).unwrap();
    match scan(&path, &topics(Transport::Raw), 0.005) {
        Err(e @ BagError::Corrupt { .. }) => {
            let text = e.to_string();
            assert!(text.starts_with(&path.display().to_string()), "{text}");
            assert!(text.contains("corrupt at byte"), "{text}");
        }
        other => panic!("expected a corrupt chunk, got {other:?}"),
    }
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn a_bag_cut_short_is_truncated_and_an_unfinished_writer_leaves_nothing() {
    let d = dir("cut");
    let path = d.join("b.mcap");
    write(&path, 3, Compression::Zstd, true, false);
    let good = std::fs::read(&path).unwrap();
    for keep in [good.len() - 1, good.len() - 40, good.len() / 2, 20] {
        std::fs::write(&path, &good[..keep]).unwrap();
        match scan(&path, &topics(Transport::Raw), 0.005) {
            Err(e @ BagError::Truncated { .. }) => {
                assert!(e.to_string().contains("truncated"), "{e}");
            }
            other => panic!("{keep} bytes: expected truncated, got {other:?}"),
        }
    }
    let unfinished = d.join("unfinished.mcap");
    let mut w = BagWriter::create(&unfinished, Compression::Zstd).unwrap();
    w.write("/other", &schema::STRING, 1, &StringMsg::default())
        .unwrap();
    drop(w);
    assert!(!unfinished.exists());
    assert!(!d.join("unfinished.mcap.partial").exists());
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn another_schema_on_an_image_topic_is_named() {
    let d = dir("schema");
    let path = d.join("b.mcap");
    let mut w = BagWriter::create(&path, Compression::Zstd).unwrap();
    w.write("/c", &schema::STRING, 1, &StringMsg::default())
        .unwrap();
    w.finish().unwrap();
    match scan(&path, &topics(Transport::Raw), 0.005) {
        Err(e @ BagError::Schema { .. }) => {
            let text = e.to_string();
            assert!(
                text.contains("/c carries std_msgs/msg/String, not sensor_msgs/msg/Image"),
                "{text}"
            );
        }
        other => panic!("expected the schema named, got {other:?}"),
    }
    let _ = std::fs::remove_dir_all(&d);
}
