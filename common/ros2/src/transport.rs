//! Camera images as `image_transport` sends them: raw `sensor_msgs/Image`, or
//! `sensor_msgs/CompressedImage` from the `compressed` plugin (colour: jpeg or png) and
//! the `compressedDepth` plugin (depth: a 12-byte `ConfigHeader` {format i32 = 0,
//! depthParam [f32; 2]}, then a 16-bit gray PNG; `16UC1` millimetres as they are,
//! `32FC1` as quantised inverse depth, depth = A / (value - B), value 0 = no return).
//! Decoded into a raw image kept by the decoder (its buffers reused frame to frame), in
//! the source stage, so the tracker only ever sees frame planes. Every error names the
//! topic and the stamp.

use crate::image::ImageError;
use crate::msg::{CompressedImage, Header, Image};
use ::image::codecs::jpeg::JpegDecoder;
use ::image::codecs::png::PngDecoder;
use ::image::{ColorType, ImageDecoder};
use std::io::Cursor;

/// A camera image of either transport.
#[derive(Clone, Debug, PartialEq)]
pub enum TransportImage {
    /// `sensor_msgs/Image`.
    Raw(Image),
    /// `sensor_msgs/CompressedImage`.
    Compressed(CompressedImage),
}

impl TransportImage {
    /// Its header.
    pub fn header(&self) -> &Header {
        match self {
            Self::Raw(image) => &image.header,
            Self::Compressed(image) => &image.header,
        }
    }
}

/// Bytes of `ConfigHeader` before the PNG of a compressedDepth image.
pub const DEPTH_HEADER_BYTES: usize = 12;
/// `ConfigHeader::format` of compressedDepth: `INV_DEPTH`, the only format it writes.
const INV_DEPTH: i32 = 0;
/// Largest decoded image: a 4K `rgba8` frame is 33 MB; a header claiming more is bad.
const MAX_DECODED_BYTES: u64 = 256 << 20;

/// Decodes the compressed images of one topic into a raw image it keeps.
#[derive(Default)]
pub struct TransportDecoder {
    decoded: Image,
    inverse_depth: Vec<u8>,
}

impl TransportDecoder {
    /// A decoder with empty buffers.
    pub fn new() -> Self {
        Self::default()
    }

    /// The colour image: the raw one as it is, a compressed one decoded (jpeg or png, to
    /// `rgb8`, `rgba8` or `mono8`).
    ///
    /// # Errors
    /// [`ImageError`] naming `topic`, the stamp and what is wrong with the format or data.
    pub fn colour<'a>(
        &'a mut self,
        image: &'a TransportImage,
        topic: &str,
    ) -> Result<&'a Image, ImageError> {
        let message = match image {
            TransportImage::Raw(raw) => return Ok(raw),
            TransportImage::Compressed(message) => message,
        };
        let fail = |reason: String| error(message, topic, reason);
        let codec = message.format.to_ascii_lowercase();
        let png = message.data.starts_with(PNG_SIGNATURE);
        let jpeg = message.data.starts_with(&[0xFF, 0xD8]);
        if codec.contains("compresseddepth") {
            return Err(fail(format!(
                "format {:?} is a depth image on the colour topic",
                message.format
            )));
        }
        let claims_png = codec.contains("png");
        let claims_jpeg = codec.contains("jpeg") || codec.contains("jpg");
        let out = &mut self.decoded;
        out.header.clone_from(&message.header);
        let data = Cursor::new(message.data.as_slice());
        let colour = if claims_png && png {
            decode_into(PngDecoder::new(data), out)
        } else if claims_jpeg && jpeg {
            decode_into(JpegDecoder::new(data), out)
        } else if claims_png || claims_jpeg {
            return Err(fail(format!(
                "format {:?}, but the data does not start like a {} file",
                message.format,
                if claims_png { "PNG" } else { "JPEG" }
            )));
        } else {
            return Err(fail(format!(
                "format {:?} is neither jpeg nor png",
                message.format
            )));
        }
        .map_err(&fail)?;
        let encoding = match colour {
            ColorType::L8 => "mono8",
            ColorType::Rgb8 => "rgb8",
            ColorType::Rgba8 => "rgba8",
            other => {
                return Err(fail(format!(
                    "a {other:?} image (format {:?}); colour is read as 8-bit gray, RGB or RGBA",
                    message.format
                )));
            }
        };
        set_encoding(out, encoding);
        Ok(&self.decoded)
    }

    /// The depth image: the raw one as it is, a compressedDepth one decoded to `16UC1`
    /// millimetres or `32FC1` metres (NaN where no return).
    ///
    /// # Errors
    /// [`ImageError`] naming `topic`, the stamp and what is wrong with the format,
    /// header or PNG.
    pub fn depth<'a>(
        &'a mut self,
        image: &'a TransportImage,
        topic: &str,
    ) -> Result<&'a Image, ImageError> {
        let message = match image {
            TransportImage::Raw(raw) => return Ok(raw),
            TransportImage::Compressed(message) => message,
        };
        let fail = |reason: String| error(message, topic, reason);
        let (encoding, codec) = match message.format.split_once(';') {
            Some((encoding, codec)) => (encoding.trim(), codec.trim()),
            None => ("", message.format.trim()),
        };
        if !(codec == "compressedDepth" || codec == "compressedDepth png") {
            return Err(fail(format!(
                "format {:?}: depth is read as `16UC1; compressedDepth png` or \
                 `32FC1; compressedDepth png`",
                message.format
            )));
        }
        let metres = match encoding {
            "16UC1" | "mono16" => false,
            "32FC1" => true,
            _ => {
                return Err(fail(format!(
                    "format {:?}: the depth encoding before `;` is not 16UC1 or 32FC1",
                    message.format
                )));
            }
        };
        let header = DepthHeader::parse(&message.data).map_err(&fail)?;
        let png = &message.data[DEPTH_HEADER_BYTES..];
        if !png.starts_with(PNG_SIGNATURE) {
            return Err(fail(format!(
                "no PNG after the {DEPTH_HEADER_BYTES}-byte compressedDepth header"
            )));
        }
        let out = &mut self.decoded;
        out.header.clone_from(&message.header);
        let target = if metres {
            &mut self.inverse_depth
        } else {
            &mut out.data
        };
        let (w, h) = decode_png_gray16(png, target).map_err(&fail)?;
        (out.width, out.height) = (w, h);
        out.is_bigendian = u8::from(cfg!(target_endian = "big"));
        if !metres {
            set_encoding(out, "16UC1");
            out.step = 2 * w;
            return Ok(&self.decoded);
        }
        let (a, b) = header.inverse_depth_params().map_err(&fail)?;
        set_encoding(out, "32FC1");
        out.step = 4 * w;
        out.data.clear();
        for v in self.inverse_depth.chunks_exact(2) {
            let v = u16::from_ne_bytes([v[0], v[1]]);
            let depth = if v == 0 {
                f32::NAN
            } else {
                a / (f32::from(v) - b)
            };
            out.data.extend_from_slice(&depth.to_ne_bytes());
        }
        Ok(&self.decoded)
    }
}

const PNG_SIGNATURE: &[u8] = &[0x89, b'P', b'N', b'G', b'\r', b'\n', 0x1A, b'\n'];

/// `ConfigHeader` of compressedDepth (native, i.e. little-endian, layout).
struct DepthHeader {
    format: i32,
    params: [f32; 2],
}

impl DepthHeader {
    fn parse(data: &[u8]) -> Result<Self, String> {
        let Some(bytes) = data.get(..DEPTH_HEADER_BYTES).filter(|_| data.len() > 16) else {
            return Err(format!(
                "{} bytes: shorter than the {DEPTH_HEADER_BYTES}-byte compressedDepth header \
                 and a PNG",
                data.len()
            ));
        };
        let word = |i: usize| [bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]];
        let header = Self {
            format: i32::from_le_bytes(word(0)),
            params: [f32::from_le_bytes(word(4)), f32::from_le_bytes(word(8))],
        };
        if header.format != INV_DEPTH {
            return Err(format!(
                "compressedDepth header format {}, not {INV_DEPTH} (INV_DEPTH)",
                header.format
            ));
        }
        Ok(header)
    }

    /// depthQuantA, depthQuantB of a `32FC1` image.
    fn inverse_depth_params(&self) -> Result<(f32, f32), String> {
        let [a, b] = self.params;
        if a.is_finite() && b.is_finite() && a > 0.0 {
            Ok((a, b))
        } else {
            Err(format!(
                "compressedDepth header quantisation A = {a}, B = {b}: A must be > 0 and both \
                 finite"
            ))
        }
    }
}

/// Sets the encoding in place (its buffer reused frame to frame).
fn set_encoding(image: &mut Image, encoding: &str) {
    image.encoding.clear();
    image.encoding.push_str(encoding);
}

fn error(message: &CompressedImage, topic: &str, reason: String) -> ImageError {
    ImageError {
        topic: topic.to_owned(),
        stamp: message.header.stamp.into(),
        reason,
    }
}

/// Decodes into `out.data` (resized, reused), setting width, height and step; the
/// colour type decoded.
fn decode_into<D: ImageDecoder>(
    decoder: ::image::ImageResult<D>,
    out: &mut Image,
) -> Result<ColorType, String> {
    let decoder = decoder.map_err(|e| e.to_string())?;
    let (w, h) = decoder.dimensions();
    let colour = decoder.color_type();
    let bytes = decoder.total_bytes();
    if bytes > MAX_DECODED_BYTES {
        return Err(format!("{w}x{h} {colour:?} is larger than a camera image"));
    }
    out.data.resize(bytes as usize, 0);
    decoder
        .read_image(&mut out.data)
        .map_err(|e| e.to_string())?;
    (out.width, out.height) = (w, h);
    out.step = w * u32::from(colour.bytes_per_pixel());
    Ok(colour)
}

/// Decodes a 16-bit gray PNG into `out` (native-endian samples); its (width, height).
fn decode_png_gray16(png: &[u8], out: &mut Vec<u8>) -> Result<(u32, u32), String> {
    let decoder = PngDecoder::new(Cursor::new(png)).map_err(|e| e.to_string())?;
    if decoder.color_type() != ColorType::L16 {
        return Err(format!(
            "a {:?} PNG after the compressedDepth header, not 16-bit gray",
            decoder.color_type()
        ));
    }
    let (w, h) = decoder.dimensions();
    let bytes = decoder.total_bytes();
    if bytes > MAX_DECODED_BYTES {
        return Err(format!("{w}x{h} is larger than a camera image"));
    }
    out.resize(bytes as usize, 0);
    decoder.read_image(out).map_err(|e| e.to_string())?;
    Ok((w, h))
}

#[cfg(test)]
#[path = "transport_tests.rs"]
mod tests;
