//! `facslab speak`: a speaking face as an MP4 with sound, and optionally its WAV, per-frame
//! ground truth (AUs, phone, viseme) and timeline.
//!
//! Order, so that a failure leaves nothing partial: the arguments, eSpeak NG and libopus are
//! checked first; the speech, frames and sound are made in memory; only then are the files
//! written (each atomically).

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};

use crate::engine::identity::IdentityTable;
use crate::engine::timeline::Timeline;
use crate::engine::{self, FrameSettings};
use crate::facs::{Catalog, EmotionTable};
use crate::speech::{self, Face, Staging, Voice};
use crate::stimuli;

/// The arguments of `facslab speak`.
#[derive(Debug, clap::Args)]
#[command(after_help = "Examples:\n  facslab speak \"The weather was fine this morning.\" --emotion happiness --identity wf1 -o happy.mp4\n  facslab speak \"I did not expect that.\" --expression 1+2+5B -o surprised.mp4 --wav --ground-truth\n  facslab speak --text-file lines.txt --emotion anger --rate 150 --pitch 40 -o angry.mp4\n  facslab speak \"Hello there.\" --timeline smile.json -o hello.mp4\n\nNeeds eSpeak NG and libopus at run time: apt-get install espeak-ng libespeak-ng1 libopus0.\nThe MP4 has an H.264 video track and an Opus sound track of the same length.")]
pub struct SpeakArgs {
    /// What the face says.
    #[arg(required_unless_present = "text_file", conflicts_with = "text_file")]
    text: Option<String>,
    /// Read what the face says from this UTF-8 file.
    #[arg(long)]
    text_file: Option<PathBuf>,
    /// The emotion shown while speaking (EmFACS prototype, e.g. happiness), at --intensity.
    #[arg(long, conflicts_with_all = ["expression", "timeline"])]
    emotion: Option<String>,
    /// Intensity of --emotion, in [0, 1].
    #[arg(long, default_value_t = 1.0, requires = "emotion")]
    intensity: f64,
    /// Any FACS expression held while speaking, e.g. 6+12.
    #[arg(long, conflicts_with = "timeline")]
    expression: Option<String>,
    /// A timeline JSON file whose AUs move the face while it speaks.
    #[arg(long)]
    timeline: Option<PathBuf>,
    /// Who speaks (see `facslab identities`).
    #[arg(long, default_value = "wm1")]
    identity: String,
    /// Frame size as WIDTHxHEIGHT [default: 485x480].
    #[arg(long, value_parser = engine::parse_size)]
    size: Option<(u32, u32)>,
    /// Frames per second.
    #[arg(long, default_value_t = 30)]
    fps: u32,
    /// Seed of the blinks and head motion.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// eSpeak NG voice (see `espeak-ng --voices`).
    #[arg(long, default_value = "en-us")]
    voice: String,
    /// Speaking rate in words per minute (80-450).
    #[arg(long, default_value_t = 175)]
    rate: u32,
    /// Base pitch (0-100).
    #[arg(long, default_value_t = 50)]
    pitch: u32,
    /// Output MP4.
    #[arg(short, long)]
    output: PathBuf,
    /// Also write the sound as a WAV beside the MP4 (same name, .wav).
    #[arg(long)]
    wav: bool,
    /// Also write the per-frame ground truth beside the MP4 (same name, .csv): AUs, phone, viseme.
    #[arg(long)]
    ground_truth: bool,
    /// Also write the timeline to this JSON file.
    #[arg(long)]
    export_timeline: Option<PathBuf>,
    /// Rendering threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
}

/// Runs `facslab speak`.
pub fn speak_command(args: SpeakArgs) -> anyhow::Result<()> {
    if args.output.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() != Some("mp4") {
        bail!("output {} must end in .mp4", args.output.display());
    }
    let text = read_text(&args)?;
    speech::check_text(&text)?;
    let face = face_of(&args)?;
    IdentityTable::active().get(&args.identity)?;
    let voice = Voice { name: args.voice.clone(), rate_wpm: args.rate, pitch: args.pitch };
    voice.validate()?;
    speech::check_tools()?;
    let size = args.size.unwrap_or(engine::DEFAULT_SIZE);
    let staging = Staging { fps: args.fps, identity: &args.identity, size, seed: args.seed };
    let performance = speech::speak(&text, &voice, &face, staging)?;
    performance.timeline.validate(Catalog::built_in()).context("the speaking face's timeline")?;
    let sound = speech::encode_sound(&performance.samples, performance.sample_rate)?;
    let settings = FrameSettings { width: size.0, height: size.1, threads: Some(1), ..Default::default() };
    let pool = rayon::ThreadPoolBuilder::new().num_threads(args.threads.unwrap_or(0)).build()?;
    let bar = crate::progress::bar(performance.timeline.frame_count() as u64, "frames", "speak");
    let bytes = pool.install(|| {
        stimuli::render_video(&performance.timeline, settings, None, true, None, None, Some(sound), &mut |frame, _| bar.set_position(frame as u64 + 1))
    })?;
    bar.finish_and_clear();
    stimuli::build::write_atomic(&args.output, &bytes)?;
    if args.wav {
        stimuli::build::write_atomic(&args.output.with_extension("wav"), &speech::audio::wav_bytes(&performance.samples, performance.sample_rate))?;
    }
    if args.ground_truth {
        let csv = stimuli::manifest::speech_ground_truth_csv(&performance.timeline, &performance.frames);
        stimuli::build::write_atomic(&args.output.with_extension("csv"), csv.as_bytes())?;
    }
    if let Some(path) = &args.export_timeline {
        stimuli::build::write_atomic(path, performance.timeline.to_json().as_bytes())?;
    }
    Ok(())
}

fn read_text(args: &SpeakArgs) -> anyhow::Result<String> {
    match (&args.text, &args.text_file) {
        (Some(text), _) => Ok(text.clone()),
        (None, Some(path)) => {
            let bytes = std::fs::metadata(path).with_context(|| format!("reading {}", path.display()))?.len();
            if bytes > 4 * speech::MAX_TEXT_CHARS as u64 {
                bail!("{} is {bytes} bytes; a text to speak has at most {} characters", path.display(), speech::MAX_TEXT_CHARS);
            }
            std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))
        }
        (None, None) => bail!("give the text to speak, or --text-file"),
    }
}

fn face_of(args: &SpeakArgs) -> anyhow::Result<Face> {
    if let Some(label) = &args.emotion {
        if !(args.intensity.is_finite() && (0.0..=1.0).contains(&args.intensity)) {
            bail!("--intensity {} must be in [0, 1]", args.intensity);
        }
        let table = EmotionTable::built_in();
        let emotion = table.get(label).with_context(|| format!("--emotion `{}` is not an EmFACS emotion", label.chars().take(32).collect::<String>()))?;
        return Ok(Face::Held(emotion.expression.scaled(args.intensity)));
    }
    if let Some(text) = &args.expression {
        if text.len() > crate::facs::MAX_NOTATION_LEN {
            bail!("the expression has {} characters; at most {}", text.len(), crate::facs::MAX_NOTATION_LEN);
        }
        return Ok(Face::Held(Catalog::built_in().parse(text)?));
    }
    if let Some(path) = &args.timeline {
        return Ok(Face::Timeline(read_timeline(path)?));
    }
    Ok(Face::Held(Catalog::built_in().parse("0")?))
}

fn read_timeline(path: &Path) -> anyhow::Result<Timeline> {
    let bytes = std::fs::metadata(path).with_context(|| format!("reading {}", path.display()))?.len();
    if bytes > engine::timeline::MAX_JSON_BYTES as u64 {
        bail!("{} is {bytes} bytes; a timeline has at most 4 MiB", path.display());
    }
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let timeline = Timeline::from_json(&text).with_context(|| format!("in {}", path.display()))?;
    timeline.validate(Catalog::built_in()).with_context(|| format!("in {}", path.display()))?;
    Ok(timeline)
}
