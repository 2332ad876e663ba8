//! Saving frames: PNG stills and animated GIFs.

use super::RenderError;
use crate::output::{AtomicFile, temp_path};
use image::codecs::gif::{GifEncoder, Repeat};
use image::{Delay, Frame, RgbaImage};
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

/// Writes `image` to `path` as a PNG (sRGB RGBA, 8 bits a channel), in full or not at
/// all: through a temporary file renamed once complete (see [`crate::output`]).
pub fn save_png(path: impl AsRef<Path>, image: &RgbaImage) -> Result<(), RenderError> {
    let path = path.as_ref();
    let io = |e: crate::output::OutputError| RenderError::Io {
        path: e.path,
        source: e.source,
    };
    let mut out = AtomicFile::create(path).map_err(io)?;
    let mut cursor = std::io::Cursor::new(Vec::new());
    image
        .write_to(&mut cursor, image::ImageFormat::Png)
        .map_err(|e| RenderError::Io {
            path: path.into(),
            source: std::io::Error::other(e),
        })?;
    std::io::Write::write_all(&mut out, cursor.get_ref()).map_err(|e| io(out.error(e)))?;
    out.commit().map_err(io)
}

/// Writes an animated, looping GIF frame by frame.
///
/// ```no_run
/// # use sandbox2d::render::{GifWriter, RenderError};
/// # fn frames() -> Vec<image::RgbaImage> { vec![] }
/// let mut gif = GifWriter::create("out.gif", 30.0)?;
/// for frame in frames() {
///     gif.push(frame)?;
/// }
/// gif.finish()?;
/// # Ok::<(), RenderError>(())
/// ```
///
/// GIF stores delays in whole hundredths of a second (centiseconds) and 256 colours a
/// frame (quantised by the encoder), so it suits previews rather than measurements. A
/// frame interval that is not a whole number of centiseconds (1/60 s is 1.67 cs) is kept
/// on average: frame `k` is shown from `round(k * interval)` to `round((k + 1) *
/// interval)` centiseconds, so each delay is within 1 cs of the interval and the whole
/// animation's length is within 1 cs of `frames * interval`. Browsers show delays under
/// 2 cs as 10 cs; an interval of 2 cs or more (e.g. `--every 2` at 60 Hz) plays right
/// everywhere.
///
/// The file is written to a temporary name beside `path` and renamed to `path` by
/// [`GifWriter::finish`] once the trailer is written; dropped unfinished (an error, an
/// interrupt), the writer removes it, so no GIF without a trailer is left behind.
pub struct GifWriter {
    encoder: Option<GifEncoder<TrackedWriter>>,
    /// The first write error, recorded by the writer (the GIF encoder writes its trailer
    /// and flushes on drop, where it cannot return errors).
    error: Arc<Mutex<Option<std::io::Error>>>,
    path: PathBuf,
    temp: PathBuf,
    /// The interval between frames in centiseconds (GIF's unit), not rounded.
    interval_cs: f64,
    size: Option<[u32; 2]>,
    frames: usize,
}

impl GifWriter {
    /// Creates `path` for an animation shown at `fps` frames per second (clamped to
    /// 0.1..=100, GIF's range), looping forever, with the encoder's default quality.
    pub fn create(path: impl AsRef<Path>, fps: f32) -> Result<Self, RenderError> {
        Self::create_with_speed(path, fps, 10)
    }

    /// As [`GifWriter::create`], with the colour quantiser's `speed` in 1..=30 (1 = best
    /// colours and slowest, 30 = fastest).
    pub fn create_with_speed(
        path: impl AsRef<Path>,
        fps: f32,
        speed: i32,
    ) -> Result<Self, RenderError> {
        let path = path.as_ref().to_path_buf();
        let temp = temp_path(&path);
        let file = crate::output::create_tracked(&temp).map_err(|source| RenderError::Io {
            path: path.clone(),
            source,
        })?;
        let error = Arc::new(Mutex::new(None));
        let writer = TrackedWriter {
            inner: BufWriter::new(file),
            error: error.clone(),
        };
        let mut encoder = GifEncoder::new_with_speed(writer, speed.clamp(1, 30));
        encoder
            .set_repeat(Repeat::Infinite)
            .map_err(|e| RenderError::Io {
                path: path.clone(),
                source: std::io::Error::other(e),
            })?;
        let fps = if fps.is_finite() {
            fps.clamp(0.1, 100.0)
        } else {
            30.0
        };
        Ok(Self {
            encoder: Some(encoder),
            error,
            path,
            temp,
            interval_cs: 100.0 / f64::from(fps),
            size: None,
            frames: 0,
        })
    }

    /// Appends a frame; every frame must have the first one's size.
    pub fn push(&mut self, frame: RgbaImage) -> Result<(), RenderError> {
        let got = [frame.width(), frame.height()];
        match self.size {
            Some(expected) if expected != got => {
                return Err(RenderError::FrameSize { expected, got });
            }
            _ => self.size = Some(got),
        }
        let delay = self.next_delay();
        let encoder = self
            .encoder
            .as_mut()
            .ok_or(RenderError::Gpu("GIF writer already finished".into()))?;
        encoder
            .encode_frame(Frame::from_parts(frame, 0, 0, delay))
            .map_err(|e| RenderError::Io {
                path: self.path.clone(),
                source: std::io::Error::other(e),
            })?;
        self.frames += 1;
        Ok(())
    }

    /// The delay of the next frame: the centiseconds from its start to the next frame's,
    /// both rounded on the animation's timeline so that rounding errors do not add up.
    /// (The encoder stores a delay's milliseconds divided by 10, so it is given whole
    /// centiseconds times 10.)
    fn next_delay(&self) -> Delay {
        let k = self.frames as f64;
        let start = (k * self.interval_cs).round();
        let end = ((k + 1.0) * self.interval_cs).round();
        let cs = (end - start).clamp(1.0, f64::from(u16::MAX)) as u32;
        Delay::from_numer_denom_ms(cs * 10, 1)
    }

    /// Frames written so far.
    pub fn frame_count(&self) -> usize {
        self.frames
    }

    /// The file being written.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Writes the trailer, closes the file and gives it its final name.
    pub fn finish(mut self) -> Result<(), RenderError> {
        self.close()?;
        std::fs::rename(&self.temp, &self.path).map_err(|source| RenderError::Io {
            path: self.path.clone(),
            source,
        })?;
        crate::output::untrack(&self.temp);
        Ok(())
    }

    fn close(&mut self) -> Result<(), RenderError> {
        // Dropping the encoder writes the trailer; dropping its writer flushes the file.
        drop(self.encoder.take());
        let error = self.error.lock().map(|mut e| e.take()).unwrap_or(None);
        match error {
            Some(source) => Err(RenderError::Io {
                path: self.path.clone(),
                source,
            }),
            None => Ok(()),
        }
    }
}

/// A buffered file that remembers its first error, so one raised while the GIF encoder
/// is dropped still reaches [`GifWriter::finish`].
struct TrackedWriter {
    inner: BufWriter<File>,
    error: Arc<Mutex<Option<std::io::Error>>>,
}

impl TrackedWriter {
    fn record<T>(&self, r: std::io::Result<T>) -> std::io::Result<T> {
        if let Err(e) = &r
            && let Ok(mut slot) = self.error.lock()
            && slot.is_none()
        {
            *slot = Some(std::io::Error::new(e.kind(), e.to_string()));
        }
        r
    }
}

impl std::io::Write for TrackedWriter {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let r = self.inner.write(buf);
        self.record(r)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        let r = self.inner.flush();
        self.record(r)
    }
}

impl Drop for TrackedWriter {
    fn drop(&mut self) {
        let r = std::io::Write::flush(&mut self.inner);
        let _ = self.record(r);
    }
}

impl Drop for GifWriter {
    fn drop(&mut self) {
        // Unfinished (or finish() failed before the rename): the GIF is incomplete, so
        // its temporary file goes.
        let _ = self.close();
        let _ = std::fs::remove_file(&self.temp);
        crate::output::untrack(&self.temp);
    }
}
