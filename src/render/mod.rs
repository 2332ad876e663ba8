//! GPU rendering of a [`crate::draw::DrawList`] with wgpu (feature `render`):
//! off-screen to images ([`Renderer::render_to_image`], [`capture`]) or, through
//! [`Renderer::draw`], into any texture view such as a window's surface.

pub mod capture;
pub mod compare;
pub mod frames;
mod gpu;
pub mod text;

pub use capture::{GifWriter, save_png};
pub use frames::{FrameJob, FramesError, FramesWritten, frame_name, render_frames};
#[cfg(feature = "app")]
pub(crate) use gpu::premultiplied_pipeline;
pub use gpu::{OFFSCREEN_FORMAT, Renderer, SAMPLE_COUNT, default_samples};

/// The wgpu this renderer is built on, for callers that make devices, surfaces and encoders.
pub use wgpu;

/// What can go wrong while rendering or saving frames.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// No GPU adapter (not even a software one such as llvmpipe) was found.
    #[error(
        "no graphics adapter found for backends {backends} ({reason}); without a GPU, install \
         Mesa (llvmpipe via GL/EGL, or lavapipe for Vulkan) or set WGPU_BACKEND=gl"
    )]
    NoAdapter {
        /// The backends that were searched.
        backends: String,
        /// wgpu's explanation.
        reason: String,
    },
    /// The adapter refused to create a device.
    #[error("could not create a GPU device: {0}")]
    RequestDevice(#[from] wgpu::RequestDeviceError),
    /// A frame size of zero, or beyond the device's texture limit.
    #[error("frame size {width}x{height} is not supported (each side must be 1..={max})")]
    InvalidSize {
        /// Requested width in pixels.
        width: u32,
        /// Requested height in pixels.
        height: u32,
        /// The device's largest texture side.
        max: u32,
    },
    /// `render_to_image` on a renderer built for another target format.
    #[error("render_to_image needs a renderer for Rgba8UnormSrgb, this one targets {format}")]
    WrongFormat {
        /// The renderer's format.
        format: String,
    },
    /// A GPU operation failed (validation, mapping, polling).
    #[error("GPU error: {0}")]
    Gpu(String),
    /// Encoding or writing an image failed.
    #[error("image: {0}")]
    Image(#[from] image::ImageError),
    /// A file could not be created or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: std::path::PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// A GIF frame whose size differs from the first frame's.
    #[error("GIF frame is {got:?} pixels but the animation is {expected:?}")]
    FrameSize {
        /// The first frame's size.
        expected: [u32; 2],
        /// This frame's size.
        got: [u32; 2],
    },
}
