//! WAV files: impulse responses out as 32-bit float, audio in from the
//! common PCM formats.

use std::fs::File;
use std::io::{BufWriter, Seek, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use hound::{SampleFormat, WavReader, WavSpec, WavWriter};

use super::ImpulseResponse;
use crate::{Error, Result};

/// Writes `ir` to `path` as a 32-bit float WAV. The file is written under a
/// temporary name in the same directory and renamed into place once it is
/// complete and synced, so a crash never leaves a half-written file at
/// `path` (a stale temporary file may remain).
///
/// Errors: an impulse response with no channels, channels of different
/// lengths, a zero sample rate, more than 65535 channels or a non-finite
/// sample; or any I/O failure.
pub fn write_wav(path: &Path, ir: &ImpulseResponse) -> Result<()> {
    validate(ir)?;
    let fail = |reason: String| Error::Audio {
        path: path.display().to_string(),
        reason,
    };
    let temporary = temporary_path(path).ok_or_else(|| fail("not a file path".into()))?;
    let written = (|| -> std::result::Result<(), String> {
        let file = File::create(&temporary).map_err(|e| e.to_string())?;
        let mut writer = BufWriter::new(file);
        encode(&mut writer, ir).map_err(|e| e.to_string())?;
        let file = writer.into_inner().map_err(|e| e.error().to_string())?;
        file.sync_all().map_err(|e| e.to_string())?;
        std::fs::rename(&temporary, path).map_err(|e| e.to_string())
    })();
    if written.is_err() {
        // Best effort: the error being reported matters more than the
        // leftover file.
        let _ = std::fs::remove_file(&temporary);
    }
    written.map_err(fail)
}

/// Writes `ir` as a 32-bit float WAV to `writer`. Same errors as
/// [`write_wav`].
pub fn write_wav_to<W: Write + Seek>(writer: W, ir: &ImpulseResponse) -> Result<()> {
    validate(ir)?;
    encode(writer, ir).map_err(|e| Error::Audio {
        path: "<writer>".into(),
        reason: e.to_string(),
    })
}

/// Reads a WAV file: its sample rate and one signal per channel, integer
/// samples scaled so that full scale is ±1. Accepts 16-, 24- and 32-bit integer and 32-bit float samples.
///
/// Errors: a missing or malformed file, or any other sample format.
pub fn read_wav(path: &Path) -> Result<(u32, Vec<Vec<f32>>)> {
    let fail = |reason: String| Error::Audio {
        path: path.display().to_string(),
        reason,
    };
    let mut reader = WavReader::open(path).map_err(|e| fail(e.to_string()))?;
    let spec = reader.spec();
    let channels = usize::from(spec.channels);
    if channels == 0 || spec.sample_rate == 0 {
        return Err(fail(
            "the header declares no channels or no sample rate".into(),
        ));
    }
    let interleaved: std::result::Result<Vec<f32>, hound::Error> =
        match (spec.sample_format, spec.bits_per_sample) {
            (SampleFormat::Float, 32) => reader.samples::<f32>().collect(),
            (SampleFormat::Int, 16) => scaled::<i16, _>(&mut reader, 15),
            (SampleFormat::Int, 24) => scaled::<i32, _>(&mut reader, 23),
            (SampleFormat::Int, 32) => scaled::<i32, _>(&mut reader, 31),
            (format, bits) => {
                return Err(fail(format!(
                    "unsupported sample format: {bits}-bit {}; use 16-, 24- or 32-bit integer or 32-bit float",
                    if format == SampleFormat::Float { "float" } else { "integer" }
                )))
            }
        };
    let interleaved = interleaved.map_err(|e| fail(e.to_string()))?;
    if interleaved.len() % channels != 0 {
        return Err(fail("the data ends in the middle of a frame".into()));
    }
    let frames = interleaved.len() / channels;
    let signals = (0..channels)
        .map(|c| {
            (0..frames)
                .map(|frame| interleaved[frame * channels + c])
                .collect()
        })
        .collect();
    Ok((spec.sample_rate, signals))
}

/// Integer samples of `reader` divided by 2^`shift`, the full scale of
/// their bit depth.
fn scaled<S, R>(
    reader: &mut WavReader<R>,
    shift: i32,
) -> std::result::Result<Vec<f32>, hound::Error>
where
    S: hound::Sample + Into<f64>,
    R: std::io::Read,
{
    let full_scale = 2f64.powi(shift);
    reader
        .samples::<S>()
        .map(|s| s.map(|s| (s.into() / full_scale) as f32))
        .collect()
}

fn validate(ir: &ImpulseResponse) -> Result<()> {
    let problem = if ir.channels.is_empty() {
        "it has no channels".to_owned()
    } else if ir.channels.len() > usize::from(u16::MAX) {
        format!(
            "it has {} channels; WAV holds at most {}",
            ir.channels.len(),
            u16::MAX
        )
    } else if ir.channels.iter().any(|c| c.len() != ir.channels[0].len()) {
        "its channels differ in length".to_owned()
    } else if ir.sample_rate == 0 {
        "its sample rate is zero".to_owned()
    } else if ir.channels.iter().flatten().any(|s| !s.is_finite()) {
        "it has a non-finite sample".to_owned()
    } else {
        return Ok(());
    };
    Err(Error::InvalidAudio(format!(
        "cannot write the impulse response as WAV: {problem}"
    )))
}

fn encode<W: Write + Seek>(writer: W, ir: &ImpulseResponse) -> hound::Result<()> {
    let spec = WavSpec {
        channels: ir.channels.len() as u16,
        sample_rate: ir.sample_rate,
        bits_per_sample: 32,
        sample_format: SampleFormat::Float,
    };
    let mut wav = WavWriter::new(writer, spec)?;
    for frame in 0..ir.channels[0].len() {
        for channel in &ir.channels {
            wav.write_sample(channel[frame])?;
        }
    }
    wav.finalize()
}

/// A name for the temporary file beside `path`, unique within this process
/// and among processes: `.{name}.{pid}.{counter}.tmp`.
fn temporary_path(path: &Path) -> Option<PathBuf> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let name = path.file_name()?.to_string_lossy();
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let temporary = format!(".{name}.{}.{n}.tmp", std::process::id());
    Some(path.with_file_name(temporary))
}

#[cfg(test)]
mod tests {
    use std::io::Cursor;

    use super::*;

    /// A fresh, empty directory for one test.
    fn scratch_dir(test: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("frusta-wav-{}-{test}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    fn stereo() -> ImpulseResponse {
        ImpulseResponse {
            sample_rate: 44_100,
            channels: vec![vec![0.5, -0.25, 1e-7, 0.0], vec![-1.0, 0.75, 0.125, 3.0]],
        }
    }

    fn write_int(path: &Path, bits: u16, samples: &[i32]) {
        let spec = WavSpec {
            channels: 1,
            sample_rate: 8000,
            bits_per_sample: bits,
            sample_format: SampleFormat::Int,
        };
        let mut writer = WavWriter::create(path, spec).unwrap();
        for &s in samples {
            if bits <= 16 {
                writer.write_sample(s as i16).unwrap();
            } else {
                writer.write_sample(s).unwrap();
            }
        }
        writer.finalize().unwrap();
    }

    #[test]
    fn float_round_trip_is_exact_and_leaves_no_temporary_file() {
        let dir = scratch_dir("round-trip");
        let path = dir.join("ir.wav");
        write_wav(&path, &stereo()).unwrap();
        let (rate, channels) = read_wav(&path).unwrap();
        assert_eq!(rate, 44_100);
        assert_eq!(channels, stereo().channels);
        let names: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, ["ir.wav"]);
        // Overwriting replaces the file whole.
        let mono = ImpulseResponse {
            sample_rate: 48_000,
            channels: vec![vec![0.25; 10]],
        };
        write_wav(&path, &mono).unwrap();
        assert_eq!(read_wav(&path).unwrap(), (48_000, mono.channels));
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn writing_to_a_stream_gives_the_same_bytes_as_the_file() {
        let dir = scratch_dir("stream");
        let path = dir.join("ir.wav");
        write_wav(&path, &stereo()).unwrap();
        let mut bytes = Cursor::new(Vec::new());
        write_wav_to(&mut bytes, &stereo()).unwrap();
        assert_eq!(bytes.into_inner(), std::fs::read(&path).unwrap());
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn integer_formats_read_at_full_scale() {
        let dir = scratch_dir("int");
        for (bits, full) in [(16u16, 1i64 << 15), (24, 1 << 23), (32, 1 << 31)] {
            let path = dir.join(format!("{bits}.wav"));
            let samples = [(-full) as i32, (full / 2) as i32, 0, (full - 1) as i32];
            write_int(&path, bits, &samples);
            let (rate, channels) = read_wav(&path).unwrap();
            assert_eq!(rate, 8000);
            assert_eq!(channels.len(), 1);
            assert_eq!(&channels[0][..3], &[-1.0, 0.5, 0.0], "{bits}-bit");
            assert!(channels[0][3] <= 1.0 && channels[0][3] > 0.999);
        }
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn other_formats_and_malformed_files_are_errors() {
        let dir = scratch_dir("bad");
        let eight_bit = dir.join("8.wav");
        write_int(&eight_bit, 8, &[1, 2, 3]);
        let err = read_wav(&eight_bit).unwrap_err();
        assert!(err.to_string().contains("8-bit"), "{err}");
        let garbage = dir.join("garbage.wav");
        std::fs::write(&garbage, b"RIFF\x10\0\0\0WAVEfmt nonsense").unwrap();
        assert!(matches!(read_wav(&garbage), Err(Error::Audio { .. })));
        let mut truncated = Cursor::new(Vec::new());
        write_wav_to(&mut truncated, &stereo()).unwrap();
        let mut bytes = truncated.into_inner();
        bytes.truncate(bytes.len() - 6);
        let cut = dir.join("cut.wav");
        std::fs::write(&cut, &bytes).unwrap();
        assert!(read_wav(&cut).is_err());
        assert!(read_wav(&dir.join("missing.wav")).is_err());
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn unwritable_responses_and_paths_are_errors() {
        let dir = scratch_dir("unwritable");
        let path = dir.join("ir.wav");
        for channels in [vec![], vec![vec![0.0], vec![]], vec![vec![f32::NAN]]] {
            let ir = ImpulseResponse {
                sample_rate: 48_000,
                channels,
            };
            assert!(matches!(write_wav(&path, &ir), Err(Error::InvalidAudio(_))));
        }
        let missing_dir = dir.join("no-such-dir").join("ir.wav");
        assert!(matches!(
            write_wav(&missing_dir, &stereo()),
            Err(Error::Audio { .. })
        ));
        assert!(write_wav(Path::new("/"), &stereo()).is_err());
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0);
        std::fs::remove_dir_all(dir).unwrap();
    }
}
