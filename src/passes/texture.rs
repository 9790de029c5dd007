//! All views of a light field in one 2D array texture (one layer per view, in the light
//! field's row-major order), uploaded through one staging buffer and one submission.
//!
//! Two storages ([`ViewStorage`]):
//! - `Srgb8`: RGBA8 as the files store it, with MUTABLE_FORMAT and two views of the same
//!   texels: `UNORM` (texels as stored: encoded averaging, or exact decoding in the shader) and
//!   `SRGB` (the sampler decodes before filtering; lavapipe's decode is biased by about +3e-4).
//! - `Linear16`: RGBA16 UNORM holding linear light decoded exactly on the CPU (error below
//!   1e-5), so hardware bilinear filtering averages exact linear values. Twice the memory.
//!   Encoded averaging from it re-encodes each texel exactly in the shader before the
//!   shader's own bilinear filter.

use ash::vk;

use rayon::prelude::*;

use crate::color;
use crate::error::{Error, Result};
use crate::gpu::resources::{Image, ImageDesc};
use crate::gpu::upload::{upload_images, ImageRegion, Staging};
use crate::gpu::GpuContext;
use crate::lightfield::LightField;
use crate::refocus::prefilter;
use crate::refocus::settings::ViewStorage;

/// The Vulkan format of the views in `storage`.
fn storage_format(storage: ViewStorage) -> vk::Format {
    match storage {
        ViewStorage::Srgb8 => vk::Format::R8G8B8A8_UNORM,
        ViewStorage::Linear16 => vk::Format::R16G16B16A16_UNORM,
    }
}

/// Bytes of one texel in `storage`.
fn texel_bytes(storage: ViewStorage) -> u64 {
    match storage {
        ViewStorage::Srgb8 => 4,
        ViewStorage::Linear16 => 8,
    }
}

/// The device limits that decide whether a light field fits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TextureLimits {
    pub max_layers: u32,
    pub max_dimension: u32,
    /// Largest device-local heap, bytes.
    pub heap_bytes: u64,
    /// Largest single allocation, bytes.
    pub max_allocation: u64,
}

impl TextureLimits {
    /// The limits of `ctx`'s device.
    pub fn of(ctx: &GpuContext) -> Self {
        let mut m3 = vk::PhysicalDeviceMaintenance3Properties::default();
        let mut p2 = vk::PhysicalDeviceProperties2::default().push_next(&mut m3);
        // SAFETY: valid physical device and chained structures.
        unsafe {
            ctx.instance
                .get_physical_device_properties2(ctx.physical, &mut p2)
        };
        let limits = &ctx.properties.limits;
        TextureLimits {
            max_layers: limits.max_image_array_layers,
            max_dimension: limits.max_image_dimension2_d,
            heap_bytes: ctx.device_local_heap(),
            max_allocation: m3.max_memory_allocation_size,
        }
    }
}

/// Checks that `views` views of `width × height` needing `bytes` of memory fit the limits.
/// Pure, so every refusal is unit-testable without a device.
pub fn check_fits(
    views: usize,
    width: u32,
    height: u32,
    bytes: u64,
    limits: &TextureLimits,
    device: &str,
) -> Result<()> {
    if views > limits.max_layers as usize {
        return Err(Error::DeviceLimit(format!(
            "the light field has {views} views but {device} holds at most {} layers in one \
             array texture (maxImageArrayLayers); use fewer views",
            limits.max_layers
        )));
    }
    if width.max(height) > limits.max_dimension {
        return Err(Error::DeviceLimit(format!(
            "views of {width}×{height} exceed {device}'s maximum image size of {} px",
            limits.max_dimension
        )));
    }
    let mib = |b: u64| b as f64 / (1024.0 * 1024.0);
    if bytes > limits.heap_bytes || bytes > limits.max_allocation {
        return Err(Error::DeviceLimit(format!(
            "the light field texture needs {:.1} MiB but {device} offers {:.1} MiB of device \
             memory and {:.1} MiB per allocation; use fewer or smaller views",
            mib(bytes),
            mib(limits.heap_bytes),
            mib(limits.max_allocation)
        )));
    }
    Ok(())
}

/// The uploaded light field. Not `Clone`; freed when dropped.
pub struct LightFieldTexture {
    pub image: Image,
    pub storage: ViewStorage,
    pub layers: u32,
    pub width: u32,
    pub height: u32,
}

/// Index of the texels-as-stored view in `image.views` (UNORM for both storages).
pub const VIEW_STORED: usize = 0;
/// Index of the hardware-decoding SRGB view in `image.views` (`Srgb8` storage only).
pub const VIEW_SRGB: usize = 1;

impl LightFieldTexture {
    /// Checks the limits, then uploads every view in `storage`.
    pub fn upload(ctx: &GpuContext, lf: &LightField, storage: ViewStorage) -> Result<Self> {
        let (w, h) = (lf.width, lf.height);
        let layers = lf.views.len();
        let format = storage_format(storage);
        let desc = ImageDesc {
            format,
            width: w,
            height: h,
            layers: layers.clamp(1, u32::MAX as usize) as u32,
            usage: vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST,
            mutable_format: storage == ViewStorage::Srgb8,
            array: true,
            mip_levels: prefilter::level_count(w, h),
        };
        let limits = TextureLimits::of(ctx);
        // Limits first: creating an image beyond maxImageArrayLayers is invalid usage.
        check_fits(layers, w, h, 0, &limits, &ctx.info.name)?;
        let bytes = desc.memory_size(ctx)?;
        check_fits(layers, w, h, bytes, &limits, &ctx.info.name)?;

        let view_formats: &[vk::Format] = match storage {
            ViewStorage::Srgb8 => &[vk::Format::R8G8B8A8_UNORM, vk::Format::R8G8B8A8_SRGB],
            ViewStorage::Linear16 => &[format],
        };
        let image = Image::new(ctx, desc, view_formats, "light field views")?;
        write_views(ctx, &image, storage, lf)?;
        Ok(LightFieldTexture {
            image,
            storage,
            layers: desc.layers,
            width: w,
            height: h,
        })
    }

    /// Replaces the texels with the views of `lf` in place (the next frame of a video): the
    /// image, its views and every descriptor that refers to them stay valid. `lf` must have
    /// as many views of the same size as the texture holds; the caller must have waited for
    /// the work that read the old texels (every headless frame does).
    ///
    /// `staging` must hold [`Self::staging_bytes`]; it is kept by the caller between frames
    /// so each frame writes into memory already mapped (allocating and faulting in tens of
    /// MiB per frame cost more than the copy itself on lavapipe).
    pub fn reupload(
        &mut self,
        ctx: &GpuContext,
        lf: &LightField,
        staging: &mut Staging,
    ) -> Result<()> {
        if lf.views.len() != self.layers as usize
            || (lf.width, lf.height) != (self.width, self.height)
        {
            return Err(Error::Invalid(format!(
                "{}: {} views of {}×{} cannot replace the uploaded {} views of {}×{}; a new \
                 light field needs a new texture",
                lf.name,
                lf.views.len(),
                lf.width,
                lf.height,
                self.layers,
                self.width,
                self.height
            )));
        }
        let storage = self.storage;
        let (offsets, total) = staging_layout(storage, self.width, self.height, self.layers);
        let regions = [ImageRegion {
            image: &self.image,
            offsets,
        }];
        staging.upload(ctx, &regions, total, |dst| {
            fill_staging(dst, storage, lf);
            Ok(())
        })
    }

    /// Bytes of all layers and levels in this texture's storage: the staging size
    /// [`Self::reupload`] needs.
    pub fn staging_bytes(&self) -> u64 {
        staging_layout(self.storage, self.width, self.height, self.layers).1
    }
}

/// Converts the views of `lf` into `storage` in one staging buffer and copies them into every
/// layer and level of `image` (one submission, waited for).
fn write_views(
    ctx: &GpuContext,
    image: &Image,
    storage: ViewStorage,
    lf: &LightField,
) -> Result<()> {
    let (offsets, total) = staging_layout(storage, lf.width, lf.height, lf.views.len() as u32);
    let regions = [ImageRegion { image, offsets }];
    upload_images(ctx, &regions, total, "light field staging", |dst| {
        fill_staging(dst, storage, lf);
        Ok(())
    })
}

/// Bytes of one view's level `l` (of a `w × h` view) in `storage`.
fn level_bytes(storage: ViewStorage, (w, h): (u32, u32), l: u32) -> usize {
    let (lw, lh) = prefilter::level_size(w, h, l);
    lw as usize * lh as usize * texel_bytes(storage) as usize
}

/// Where each level of `layers` views of `w × h` starts in the staging buffer (level after
/// level, each holding every layer: what [`fill_staging`] writes), and the bytes of all.
fn staging_layout(storage: ViewStorage, w: u32, h: u32, layers: u32) -> (Vec<u64>, u64) {
    let mut total = 0u64;
    let offsets = (0..prefilter::level_count(w, h))
        .map(|l| {
            let at = total;
            total += level_bytes(storage, (w, h), l) as u64 * layers as u64;
            at
        })
        .collect();
    (offsets, total)
}

/// Writes every view of `lf` in `storage`, layer after layer, into `dst` (views in parallel),
/// then each level of the prefilter pyramid (`refocus::prefilter`) from the one before, in the
/// stored values.
fn fill_staging(dst: &mut [u8], storage: ViewStorage, lf: &LightField) {
    let (w, h) = (lf.width, lf.height);
    let layers = lf.views.len();
    let level_bytes = |l: u32| level_bytes(storage, (w, h), l);
    let (level0, mut rest) = dst.split_at_mut(level_bytes(0) * layers);
    level0
        .par_chunks_exact_mut(level_bytes(0))
        .zip(&lf.views)
        .for_each(|(dst, v)| match storage {
            ViewStorage::Srgb8 => dst.copy_from_slice(v.image.as_raw()),
            ViewStorage::Linear16 => encode_linear16(v.image.as_raw(), dst),
        });
    let mut prev: &[u8] = level0;
    for l in 1..prefilter::level_count(w, h) {
        let (cur, tail) = std::mem::take(&mut rest).split_at_mut(level_bytes(l) * layers);
        let size = prefilter::level_size(w, h, l - 1);
        cur.par_chunks_exact_mut(level_bytes(l))
            .zip(prev.par_chunks_exact(level_bytes(l - 1)))
            .for_each(|(dst, src)| halve_stored(storage, src, size, dst));
        prev = cur;
        rest = tail;
    }
}

/// One pyramid level down in `storage`'s texels: `src` is a level of `size`, `dst` the next.
fn halve_stored(storage: ViewStorage, src: &[u8], size: (u32, u32), dst: &mut [u8]) {
    match storage {
        ViewStorage::Srgb8 => {
            let texels: Vec<[u8; 4]> = src
                .chunks_exact(4)
                .map(|c| [c[0], c[1], c[2], c[3]])
                .collect();
            let out = prefilter::halve(&texels, size, f64::from, |v| v.round() as u8);
            for (d, t) in dst.chunks_exact_mut(4).zip(out) {
                d.copy_from_slice(&t);
            }
        }
        ViewStorage::Linear16 => {
            let texels: Vec<[u16; 4]> = src
                .chunks_exact(8)
                .map(|c| std::array::from_fn(|k| u16::from_ne_bytes([c[2 * k], c[2 * k + 1]])))
                .collect();
            let out = prefilter::halve(&texels, size, f64::from, |v| v.round() as u16);
            for (d, t) in dst.chunks_exact_mut(8).zip(out) {
                for k in 0..4 {
                    d[2 * k..2 * k + 2].copy_from_slice(&t[k].to_ne_bytes());
                }
            }
        }
    }
}

/// RGBA8 sRGB texels → RGBA16 UNORM linear light (alpha stays linear in [0, 1]), rounding
/// the exact decoded value to the nearest 16-bit level.
fn encode_linear16(rgba8: &[u8], dst: &mut [u8]) {
    // One 64-bit store per texel: the four 16-bit levels packed so that their bytes land in
    // memory in R, G, B, A order with each level in native byte order. (Four 16-bit stores
    // per texel made this conversion the slowest step of a video frame's upload.)
    let table = linear16_table().map(|v| v as u64);
    let shifts: [u32; 4] = if cfg!(target_endian = "little") {
        [0, 16, 32, 48]
    } else {
        [48, 32, 16, 0]
    };
    for (src, out) in rgba8.chunks_exact(4).zip(dst.chunks_exact_mut(8)) {
        let texel = table[src[0] as usize] << shifts[0]
            | table[src[1] as usize] << shifts[1]
            | table[src[2] as usize] << shifts[2]
            | (src[3] as u64 * 257) << shifts[3];
        out.copy_from_slice(&texel.to_ne_bytes());
    }
}

/// The 16-bit linear level of every 8-bit sRGB level.
fn linear16_table() -> [u16; 256] {
    let decode = color::decode_table();
    std::array::from_fn(|i| (decode[i] * 65535.0).round() as u16)
}

#[cfg(test)]
mod tests {
    use super::*;

    const LIMITS: TextureLimits = TextureLimits {
        max_layers: 2048,
        max_dimension: 16384,
        heap_bytes: 1 << 30,
        max_allocation: 1 << 30,
    };

    #[test]
    fn linear16_levels_are_the_exact_decode_rounded() {
        let t = linear16_table();
        assert_eq!((t[0], t[255]), (0, 65535));
        for (i, &v) in t.iter().enumerate() {
            let exact = color::srgb_to_linear(i as f64 / 255.0) * 65535.0;
            assert!((v as f64 - exact).abs() <= 0.5, "level {i}: {v} vs {exact}");
        }
        let mut out = [0u8; 8];
        encode_linear16(&[255, 0, 128, 255], &mut out);
        let words: Vec<u16> = out
            .chunks_exact(2)
            .map(|c| u16::from_ne_bytes([c[0], c[1]]))
            .collect();
        assert_eq!(words, vec![65535, 0, t[128], 65535]);
    }

    #[test]
    fn fitting_light_fields_pass() {
        assert!(check_fits(81, 512, 512, 81 * 512 * 512 * 4, &LIMITS, "dev").is_ok());
    }

    #[test]
    fn too_many_layers_names_the_limit() {
        let e = check_fits(2049, 8, 8, 0, &LIMITS, "dev")
            .unwrap_err()
            .to_string();
        assert!(e.contains("2049 views") && e.contains("2048"), "{e}");
    }

    #[test]
    fn oversized_views_and_memory_are_refused() {
        let e = check_fits(4, 20000, 10, 0, &LIMITS, "dev")
            .unwrap_err()
            .to_string();
        assert!(e.contains("20000"), "{e}");
        let e = check_fits(4, 10, 10, 2 << 30, &LIMITS, "dev")
            .unwrap_err()
            .to_string();
        assert!(e.contains("MiB"), "{e}");
    }
}
