//! Held sounds of a synthetic voice (espeak-ng), with the spectral method: a steady
//! "sh" and a vowel sung on one note, stretched by sox to 0.3-2 s, must each give one
//! event whose begin and end are within 50 ms of the sound's and whose IoU is at least
//! 0.8; the vowel reports its pitch, the "sh" none. Needs espeak-ng and sox, which
//! scripts/test.sh installs.

mod common;

use std::path::Path;
use std::process::Command;

use common::*;
use onomato::analyze::detect_in_blocks;
use onomato::audio::{resample_clip, ChannelSelect, WavSource};
use onomato::config::{DetectorSettings, Method, PatternKind};
use onomato::{Detector, Pattern};

fn run(program: &str, args: &[&str]) {
    let out = Command::new(program)
        .args(args)
        .env("SOX_OPTS", "-R -D")
        .output()
        .unwrap_or_else(|e| panic!("{program} is needed (scripts/test.sh installs it): {e}"));
    assert!(
        out.status.success(),
        "{program} {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

fn read(path: &Path) -> Vec<f32> {
    let mut src = WavSource::open(path, ChannelSelect::Mix).unwrap();
    let rate = src.sample_rate();
    resample_clip(&src.read_all().unwrap(), rate, RATE).unwrap()
}

/// The spectral method's default settings.
fn spectral() -> DetectorSettings {
    DetectorSettings {
        method: Method::Spectral,
        ..DetectorSettings::default()
    }
}

/// `patterns` without the one named `name`.
fn without(patterns: Vec<Pattern>, name: &str) -> Vec<Pattern> {
    patterns.into_iter().filter(|p| &*p.name != name).collect()
}

/// The impulse patterns of `patterns`.
fn impulses(patterns: Vec<Pattern>) -> Vec<Pattern> {
    patterns
        .into_iter()
        .filter(|p| p.kind == PatternKind::Impulse)
        .collect()
}

/// Where a held sound is, as the README defines it: its first and last 10 ms frames
/// within 20 dB of its loudest. (A vowel stretched tenfold ends in single glottal pulses
/// 20-30 dB down, where the end would otherwise hang on a tenth of a decibel.)
fn span(x: &[f32]) -> (usize, usize) {
    let hop = (RATE / 100) as usize;
    let db: Vec<f32> = x
        .chunks(hop)
        .map(|c| 10.0 * (c.iter().map(|v| v * v).sum::<f32>() / c.len() as f32 + 1e-12).log10())
        .collect();
    let loudest = db.iter().cloned().fold(f32::NEG_INFINITY, f32::max);
    let first = db.iter().position(|&d| d > loudest - 20.0).unwrap();
    let last = db.iter().rposition(|&d| d > loudest - 20.0).unwrap();
    (first * hop, ((last + 1) * hop).min(x.len()))
}

#[test]
fn held_fricatives_and_vowels_of_a_voice_are_found_with_their_span() {
    let dir = temp_dir("voices");
    let p = |name: &str| dir.join(name).to_str().unwrap().to_string();
    run(
        "espeak-ng",
        &["-v", "en", "-w", &p("sh-raw.wav"), "[[SSSSSSSS]]"],
    );
    run(
        "espeak-ng",
        &[
            "-v",
            "en",
            "-m",
            "-w",
            &p("aa-raw.wav"),
            "<speak><prosody range=\"x-low\">aaaaaaaaa</prosody></speak>",
        ],
    );
    // The steady middle of each, and its first 150 ms as the enrolled take.
    run(
        "sox",
        &[&p("sh-raw.wav"), &p("sh-core.wav"), "trim", "0.1", "0.5"],
    );
    run(
        "sox",
        &[&p("aa-raw.wav"), &p("aa-core.wav"), "trim", "0.15", "0.2"],
    );
    let settings = spectral();
    let take = |core: &str| read(&dir.join(core))[..samples_for(0.15, RATE)].to_vec();
    let patterns = vec![
        Pattern::from_samples(
            "sh",
            PatternKind::Continuous,
            vec![take("sh-core.wav")],
            &settings,
        )
        .unwrap(),
        Pattern::from_samples(
            "aa",
            PatternKind::Continuous,
            vec![take("aa-core.wav")],
            &settings,
        )
        .unwrap(),
    ];
    let core_len = |core: &str| read(&dir.join(core)).len() as f64 / f64::from(RATE);
    let mut rec = vec![0.0f32; samples_for(0.3, RATE)];
    let mut truth = Vec::new();
    for (i, (label, seconds)) in [
        ("sh", 0.5),
        ("aa", 0.6),
        ("sh", 1.5),
        ("aa", 1.0),
        ("sh", 0.3),
        ("aa", 2.0),
        ("sh", 2.0),
        ("aa", 0.3),
    ]
    .into_iter()
    .enumerate()
    {
        let core = format!("{label}-core.wav");
        let tempo = format!("{}", core_len(&core) / seconds);
        let out = format!("held{i}.wav");
        run("sox", &[&p(&core), &p(&out), "tempo", "-s", &tempo]);
        let sound = read(&dir.join(&out));
        let (a, b) = span(&sound);
        let at = rec.len();
        truth.push((
            label,
            (at + a) as f64 / f64::from(RATE),
            (at + b) as f64 / f64::from(RATE),
        ));
        rec.extend_from_slice(&sound);
        rec.extend(vec![0.0; samples_for(0.5, RATE)]);
    }
    add_noise(&mut rec, 0.0005, 12);
    let mut det = Detector::new(patterns, &settings, RATE).unwrap();
    let events = detect_in_blocks(&mut det, &rec, 256);
    assert_eq!(events.len(), truth.len(), "{events:#?}\n{truth:?}");
    for (e, (label, begin, end)) in events.iter().zip(&truth) {
        let e_end = e.end.expect("held sounds have an end");
        assert_eq!(&*e.pattern, *label, "{e:?}");
        assert!(
            (e.time - begin).abs() <= 0.05,
            "begin {:.3} vs {begin:.3}: {e:?}",
            e.time
        );
        assert!(
            (e_end - end).abs() <= 0.05,
            "end {e_end:.3} vs {end:.3}: {e:?}"
        );
        let iou = (e_end.min(*end) - e.time.max(*begin)) / (e_end.max(*end) - e.time.min(*begin));
        assert!(iou >= 0.8, "IoU {iou:.3}: {e:?} vs {begin:.3}-{end:.3}");
        match *label {
            "aa" => assert!(e.pitch.is_some_and(|f| (60.0..300.0).contains(&f)), "{e:?}"),
            _ => assert_eq!(e.pitch, None, "{e:?}"),
        }
    }
}

/// A voice's words as patterns: espeak-ng says `text` and sox trims the silence around it.
fn word(dir: &Path, name: &str, text: &str, speed: &str) -> Vec<f32> {
    word_by(dir, name, text, "en", speed)
}

/// As [`word`], said by espeak-ng's `voice`.
fn word_by(dir: &Path, name: &str, text: &str, voice: &str, speed: &str) -> Vec<f32> {
    let raw = dir.join(format!("{name}-raw.wav"));
    let trimmed = dir.join(format!("{name}.wav"));
    let (raw, trimmed) = (raw.to_str().unwrap(), trimmed.to_str().unwrap());
    run("espeak-ng", &["-v", voice, "-s", speed, "-w", raw, text]);
    #[rustfmt::skip]
    run("sox", &[raw, trimmed, "silence", "1", "0.005", "1%", "reverse", "silence", "1", "0.005", "1%", "reverse"]);
    read(Path::new(trimmed))
}

/// The voice's words "tick", "pop", "pew", "boom" and its held "shhh" and "hooo", said
/// at 175 words per minute, as patterns.
fn enrolled_words(dir: &Path, settings: &DetectorSettings) -> Vec<Pattern> {
    enrolled_words_at(dir, settings, "175")
}

/// As [`enrolled_words`], said at `speed` words a minute.
fn enrolled_words_at(dir: &Path, settings: &DetectorSettings, speed: &str) -> Vec<Pattern> {
    let words = [
        ("tick", "tick", PatternKind::Impulse),
        ("pop", "pop", PatternKind::Impulse),
        ("pew", "pew", PatternKind::Impulse),
        ("boom", "boom", PatternKind::Impulse),
        ("shhh", "shhhhhhh", PatternKind::Continuous),
        ("hooo", "hoooooo", PatternKind::Continuous),
    ];
    words
        .iter()
        .map(|(name, text, kind)| {
            let take = word(dir, name, text, speed);
            Pattern::from_samples(name, *kind, vec![take], settings).unwrap()
        })
        .collect()
}

/// The paragraph of `tests/data/speech-paragraph.txt` in the same voice, with a little
/// noise.
fn paragraph(dir: &Path) -> Vec<f32> {
    let path = dir.join("speech.wav");
    let text = root().join("tests/data/speech-paragraph.txt");
    #[rustfmt::skip]
    run("espeak-ng", &["-v", "en", "-w", path.to_str().unwrap(), "-f", text.to_str().unwrap()]);
    let mut speech = read(&path);
    add_noise(&mut speech, 0.0005, 21);
    speech
}

#[test]
fn speech_by_the_enrolled_voice_is_not_taken_for_its_words_said_alone() {
    let dir = temp_dir("speech");
    let settings = spectral();
    let patterns = enrolled_words(&dir, &settings);
    let speech = paragraph(&dir);
    let minutes = speech.len() as f64 / f64::from(RATE) / 60.0;
    let per_minute = |settings: &DetectorSettings| {
        let mut det = Detector::new(patterns.clone(), settings, RATE).unwrap();
        let events = detect_in_blocks(&mut det, &speech, 256);
        (events.len() as f64 / minutes, events)
    };
    let (guarded, events) = per_minute(&settings);
    assert!(
        guarded <= 3.0,
        "{guarded:.1} false events per minute of speech: {events:#?}"
    );
    // Not only the guard: the background of other voices' speech keeps this voice's
    // consonants from passing for its words without it too (before the background,
    // 20 or more a minute passed with the guard off).
    let (unguarded, events) = per_minute(&DetectorSettings {
        speech_guard_seconds: 0.0,
        ..settings.clone()
    });
    assert!(
        unguarded <= 3.0,
        "{unguarded:.1} per minute without the guard: {events:#?}"
    );

    // Words said alone, more slowly, at several levels, are found at their onsets.
    // "pop" and "pew" begin with the same burst, and a decision 25 ms after the onset
    // cannot tell them apart, so this part enrols "pop" without "pew". "tick" opens
    // with a "t" 20 dB below its vowel, on which its take's onset must be placed as an
    // instance's is. A word's final consonant ("pop") may give a second event of its
    // own.
    let alone_patterns = without(patterns, "pew");
    for (words, seed) in [(&["pop", "boom"][..], 5), (&["tick"][..], 6)] {
        said_alone_are_found(
            &dir,
            &alone_patterns,
            &settings,
            words,
            seed,
            "140",
            as_made,
        );
    }
}

/// The samples as made, at the working rate.
fn as_made(x: Vec<f32>) -> (Vec<f32>, u32) {
    (x, RATE)
}

/// The samples (at the working rate) through a 16 kHz input.
fn at_16_khz(x: Vec<f32>) -> (Vec<f32>, u32) {
    (resample_clip(&x, RATE, 16_000).unwrap(), 16_000)
}

/// The samples through a 16 kHz source resampled back to the working rate on its way
/// in (a headset through a sound server): nothing over 6.3 kHz, at a full rate.
fn band_limited(x: Vec<f32>) -> (Vec<f32>, u32) {
    let narrow = resample_clip(&x, RATE, 16_000).unwrap();
    (resample_clip(&narrow, 16_000, RATE).unwrap(), RATE)
}

/// The words enrolled as `take` hears them, then the voice's speech and its words said
/// alone through `input`: at most 3 false events a minute of speech, and the words found
/// as [`said_alone_are_found`] asks.
fn a_voice_heard_through(
    name: &str,
    take: fn(Vec<f32>) -> (Vec<f32>, u32),
    input: fn(Vec<f32>) -> (Vec<f32>, u32),
    alone: &[&[&'static str]],
) {
    let dir = temp_dir(name);
    let settings = spectral();
    let patterns: Vec<Pattern> = without(enrolled_words(&dir, &settings), "pew")
        .into_iter()
        .map(|p| {
            let (samples, rate) = take(p.takes[0].samples.clone());
            assert_eq!(rate, RATE);
            Pattern::from_samples(&p.name, p.kind, vec![samples], &settings).unwrap()
        })
        .collect();
    let (speech, rate) = input(paragraph(&dir));
    let minutes = speech.len() as f64 / f64::from(rate) / 60.0;
    let mut det = Detector::new(patterns.clone(), &settings, rate).unwrap();
    let events = detect_in_blocks(&mut det, &speech, 256);
    let per_minute = events.len() as f64 / minutes;
    assert!(
        per_minute <= 3.0,
        "{per_minute:.1} false events per minute of speech: {events:#?}"
    );
    for (words, seed) in alone.iter().zip(5..) {
        said_alone_are_found(&dir, &patterns, &settings, words, seed, "140", input);
    }
}

/// A voice enrolled through a good microphone, then heard through a 16 kHz input (a
/// headset): nothing over 6.3 kHz reaches the detector, and a comparison over every
/// band took every word for the one its take's missing top resembled least and let
/// speech through. Only the bands the input carries are compared.
#[test]
fn a_voice_heard_through_a_16_khz_input_is_found_and_its_speech_is_not() {
    a_voice_heard_through(
        "narrow-input",
        as_made,
        at_16_khz,
        &[&["pop", "boom"], &["tick"]],
    );
}

/// The same voice enrolled and heard through a 16 kHz source resampled to a full rate on
/// its way in: the rate says nothing of the band, the takes' sudden fall at 6.3 kHz
/// does (compared over every band, 20 false events a minute of this speech passed).
/// ("boom", enrolled band-limited too, scores 0.87 against its take and 0.94
/// against the background's speech over the bands compared, at the background's margin,
/// and is left out of the words said alone.)
#[test]
fn a_voice_enrolled_and_heard_band_limited_at_a_full_rate_is_found_and_its_speech_is_not() {
    a_voice_heard_through(
        "band-limited",
        band_limited,
        band_limited,
        &[&["pop"], &["tick"]],
    );
}

/// The same voice enrolled through a good microphone and heard through a 16 kHz source
/// resampled to a full rate on its way in (a headset through a sound server): neither
/// the rate nor the takes say that the stream carries less; its own loudest frames,
/// which fall off the resampler's edge into nothing but noise, do.
#[test]
fn a_voice_enrolled_at_full_band_and_heard_band_limited_is_found_and_its_speech_is_not() {
    a_voice_heard_through(
        "full-band-takes",
        as_made,
        band_limited,
        &[&["pop", "boom"], &["tick"]],
    );
}

/// Three rounds of `words`, each said alone at `speed` words a minute with a gain of
/// -9..0 dB and 0.3-0.8 s of silence after it, heard through `input` (the samples at
/// the working rate to the input's samples and rate):
/// at least 90% must be found within 50 ms of their onset, none with another label, and
/// no word may give more than two events.
fn said_alone_are_found(
    dir: &Path,
    patterns: &[Pattern],
    settings: &DetectorSettings,
    words: &[&'static str],
    seed: u64,
    speed: &str,
    input: fn(Vec<f32>) -> (Vec<f32>, u32),
) {
    let mut rec = vec![0.0f32; samples_for(0.5, RATE)];
    let mut truth = Vec::new();
    let mut rng = Rng::new(seed);
    for round in 0..3 {
        for &name in words {
            let said = word(dir, &format!("{name}-alone-{round}"), name, speed);
            let gain = 10f32.powf(rng.range(-9.0, 0.0) as f32 / 20.0);
            truth.push((name, rec.len() as f64 / f64::from(RATE)));
            rec.extend(said.iter().map(|v| v * gain));
            rec.extend(vec![0.0; samples_for(rng.range(0.3, 0.8), RATE)]);
        }
    }
    add_noise(&mut rec, 0.0005, 22);
    let (rec, input_rate) = input(rec);
    let mut det = Detector::new(patterns.to_vec(), settings, input_rate).unwrap();
    let events = detect_in_blocks(&mut det, &rec, 256);
    let summary: Vec<String> = events
        .iter()
        .map(|e| format!("{} {:.3}", e.pattern, e.time))
        .collect();
    let at_onsets: Vec<(&str, Option<&str>)> = truth
        .iter()
        .map(|(name, at)| {
            let event = events.iter().find(|e| (e.time - at).abs() <= 0.05);
            (*name, event.map(|e| &*e.pattern))
        })
        .collect();
    let right = at_onsets.iter().filter(|(n, e)| Some(*n) == *e).count();
    assert!(
        right as f64 >= 0.9 * truth.len() as f64
            && at_onsets.iter().all(|(n, e)| e.is_none_or(|e| e == *n)),
        "{right} of {} words found: {at_onsets:?}; events {summary:?}",
        truth.len()
    );
    assert!(
        events.len() <= 2 * truth.len(),
        "more than two events per word: {summary:?}"
    );
}

/// Issue: after speech, the speech guard must let go. A word said alone 0.6 s after the
/// end of a sentence is found at its onset (the default guard looks back 0.65 s, where
/// it finds less than the 200 ms of speech it needs).
#[test]
fn a_word_said_0_6_s_after_speech_is_found() {
    let dir = temp_dir("after-speech");
    let settings = spectral();
    // Without "pew", whose first 25 ms are those of "pop" (see above).
    let patterns = without(enrolled_words(&dir, &settings), "pew");
    let speech = paragraph(&dir);
    // The paragraph's first sentence or so, cut where the voice is silent.
    let cut = {
        let mut at = samples_for(4.0, RATE).min(speech.len());
        let window = samples_for(0.02, RATE);
        while at + window < speech.len() && speech[at..at + window].iter().any(|v| v.abs() > 0.01) {
            at += window;
        }
        at
    };
    for name in ["pop", "tick", "boom"] {
        let said = word(&dir, &format!("{name}-after"), name, "140");
        let mut rec = speech[..cut].to_vec();
        rec.extend(vec![0.0; samples_for(0.6, RATE)]);
        let onset = rec.len() as f64 / f64::from(RATE);
        rec.extend(&said);
        rec.extend(vec![0.0; samples_for(0.5, RATE)]);
        add_noise(&mut rec, 0.0005, 23);
        let mut det = Detector::new(patterns.clone(), &settings, RATE).unwrap();
        let events = detect_in_blocks(&mut det, &rec, 256);
        assert!(
            events
                .iter()
                .any(|e| &*e.pattern == name && (e.time - onset).abs() <= 0.05),
            "{name} at {onset:.3}: {:?}",
            events
                .iter()
                .map(|e| format!("{} {:.3}", e.pattern, e.time))
                .collect::<Vec<_>>()
        );
    }
}

/// Issue: no rule may feed on its own decisions. A sound the guard stops on talk that
/// lies as near speech as to its pattern counts as that talk going on, but a sound
/// stopped on such sounds alone covers its span again: a stop passes on once at most.
/// An enrolled "the" (a syllable of the voice's talk, as near its speech as to its
/// take) said five times straight out of talking: the first is stopped as the talk, the
/// second on the first alone (`speech_guard*`), and from the third on each is found.
#[test]
fn a_word_said_again_and_again_straight_after_talking_is_found_from_the_third_on() {
    let dir = temp_dir("after-talking");
    let settings = spectral();
    let take = word(&dir, "the", "the", "175");
    let patterns =
        vec![Pattern::from_samples("the", PatternKind::Impulse, vec![take], &settings).unwrap()];
    let speech = paragraph(&dir);
    let mut rec = speech[..samples_for(3.3, RATE).min(speech.len())].to_vec();
    let said = word(&dir, "the-said", "the", "175");
    let mut onsets = Vec::new();
    for _ in 0..5 {
        rec.extend(vec![0.0; samples_for(0.15, RATE)]);
        onsets.push(rec.len() as f64 / f64::from(RATE));
        rec.extend(&said);
    }
    rec.extend(vec![0.0; samples_for(0.5, RATE)]);
    add_noise(&mut rec, 0.0005, 24);
    let mut det = Detector::new(patterns, &settings, RATE).unwrap();
    det.enable_explain();
    let events = detect_in_blocks(&mut det, &rec, 256);
    let records = det.take_explain().unwrap_or_default();
    let mut table = Vec::new();
    onomato::analyze::write_explain(&mut table, &records).unwrap();
    let table = String::from_utf8(table).unwrap();
    let found = |onset: f64| events.iter().any(|e| (e.time - onset).abs() <= 0.05);
    let outcome = |onset: f64| {
        records
            .iter()
            .filter(|r| (r.time - onset).abs() <= 0.05)
            .map(|r| (r.outcome, r.guard_by_stopped_speech))
            .next()
    };
    use onomato::detect::gates::Outcome;
    assert_eq!(
        outcome(onsets[0]),
        Some((Outcome::SpeechGuard, false)),
        "{table}"
    );
    assert_eq!(
        outcome(onsets[1]),
        Some((Outcome::SpeechGuard, true)),
        "{table}"
    );
    assert!(onsets[2..].iter().all(|&t| found(t)), "{table}");
    let after_talking = events.iter().filter(|e| e.time > onsets[0] - 0.05).count();
    assert_eq!(after_talking, 3, "{table}");
}

/// The detector's account of every onset it considered (`analyze --explain`'s table).
fn explained(det: &mut Detector) -> String {
    let mut table = Vec::new();
    onomato::analyze::write_explain(&mut table, &det.take_explain().unwrap_or_default()).unwrap();
    String::from_utf8(table).unwrap()
}

/// Matches `events` against `truth` (name, onset): one to one, same name, within 50 ms.
/// Returns the F1 and a readable account of both.
fn f1_against(events: &[onomato::Event], truth: &[(&str, f64)]) -> (f64, String) {
    let mut used = vec![false; events.len()];
    let mut matched = 0;
    for (name, at) in truth {
        let hit = events
            .iter()
            .enumerate()
            .filter(|(i, e)| !used[*i] && &*e.pattern == *name && (e.time - at).abs() <= 0.05)
            .min_by(|a, b| (a.1.time - at).abs().total_cmp(&(b.1.time - at).abs()));
        if let Some((i, _)) = hit {
            used[i] = true;
            matched += 1;
        }
    }
    let f1 = 2.0 * matched as f64 / (events.len() + truth.len()).max(1) as f64;
    let account = format!(
        "{matched} of {} found; truth {:?}; events {:?}",
        truth.len(),
        truth
            .iter()
            .map(|(n, t)| format!("{n} {t:.3}"))
            .collect::<Vec<_>>(),
        events
            .iter()
            .map(|e| format!("{} {:.3}", e.pattern, e.time))
            .collect::<Vec<_>>()
    );
    (f1, account)
}

/// Appends a copy of `pattern`'s take at `gain_db` to `rec`, annotated in `truth` where
/// it begins, then 0.08-0.5 s of silence drawn from `rng` (the exact-copy protocol's
/// gaps).
fn append_copy<'a>(
    rec: &mut Vec<f32>,
    truth: &mut Vec<(&'a str, f64)>,
    pattern: &'a Pattern,
    gain_db: f64,
    rng: &mut Rng,
) {
    let gain = 10f32.powf(gain_db as f32 / 20.0);
    truth.push((&*pattern.name, rec.len() as f64 / f64::from(RATE)));
    rec.extend(pattern.takes[0].samples.iter().map(|v| v * gain));
    rec.extend(vec![0.0; samples_for(rng.range(0.08, 0.5), RATE)]);
}

/// `rec`, copies of the takes of `patterns` at `truth`, with 0.3 s of silence after it
/// and noise 50 dB below full scale (`noise_seed`): every copy is found with its label,
/// and nothing else is.
fn every_copy_is_found(
    patterns: &[Pattern],
    settings: &DetectorSettings,
    mut rec: Vec<f32>,
    truth: &[(&str, f64)],
    noise_seed: u64,
) {
    rec.extend(vec![0.0; samples_for(0.3, RATE)]);
    add_noise(&mut rec, 10f64.powf(-50.0 / 20.0), noise_seed);
    let mut det = Detector::new(patterns.to_vec(), settings, RATE).unwrap();
    det.enable_explain();
    let events = detect_in_blocks(&mut det, &rec, 256);
    let (f1, account) = f1_against(&events, truth);
    assert!(
        f1 >= 0.999,
        "F1 {f1:.3}: {account}\n{}",
        explained(&mut det)
    );
}

/// Issue: exact copies of the enrolled takes must always be found, whatever came before
/// (the speech guard once stayed closed after one miss, and nothing after 2.8 s of an
/// 8 s recording of copies was found). Copies of the takes ("tick", "pew", "boom") at
/// -12..0 dB, 80-500 ms
/// apart, in noise 50 dB below full scale; half-way, one copy 40 dB down, which
/// `min_strength` stops by design. Every other copy is found with its label, and
/// nothing else is.
#[test]
fn exact_copies_of_the_takes_are_all_found_at_any_gain_in_noise_even_after_a_miss() {
    let dir = temp_dir("exact-copies");
    let settings = spectral();
    // "pop" and "pew" share their first 25 ms (see above): "pew" stays, as its soft
    // start is what a stream places differently by the noise around it.
    let patterns = without(impulses(enrolled_words(&dir, &settings)), "pop");
    let mut rng = Rng::new(31);
    let mut rec = vec![0.0f32; samples_for(0.3, RATE)];
    let mut truth = Vec::new();
    for copy in 0..32 {
        let p = &patterns[(rng.next_u64() % patterns.len() as u64) as usize];
        let take = &p.takes[0].samples;
        let missed = copy == 16;
        let gain_db = if missed { -40.0 } else { rng.range(-12.0, 0.0) };
        let gain = 10f32.powf(gain_db as f32 / 20.0);
        if !missed {
            truth.push((&*p.name, rec.len() as f64 / f64::from(RATE)));
        }
        rec.extend(take.iter().map(|v| v * gain));
        rec.extend(vec![0.0; samples_for(rng.range(0.08, 0.5), RATE)]);
    }
    every_copy_is_found(&patterns, &settings, rec, &truth, 32);
}

/// Issue: exact copies are always found, at any gain from -12 to 0 dB in noise 50 dB
/// down. A word that begins softly ("fish", "sip", "thin"), copied 10-12 dB under its
/// take, has its first 25 ms within a few dB of the noise: that window matched no take
/// well enough (or lay nearer speech than its take) and 2 of these 24 copies were
/// missed. Its waveform over a quarter of a second is the take's, and finds it (the
/// copies stage).
#[test]
fn exact_copies_whose_soft_start_the_noise_hides_are_found() {
    let dir = temp_dir("soft-copies");
    let settings = spectral();
    let patterns: Vec<Pattern> = [("fish", "fish"), ("sip", "sip"), ("thin", "thin")]
        .iter()
        .map(|(name, text)| {
            let take = word(&dir, name, text, "175");
            Pattern::from_samples(name, PatternKind::Impulse, vec![take], &settings).unwrap()
        })
        .collect();
    let mut rng = Rng::new(7);
    let mut rec = vec![0.0f32; samples_for(0.3, RATE)];
    let mut truth = Vec::new();
    for copy in 0..24 {
        let gain_db = if copy % 2 == 0 {
            rng.range(-12.0, -10.0)
        } else {
            rng.range(-6.0, 0.0)
        };
        let p = &patterns[copy % patterns.len()];
        append_copy(&mut rec, &mut truth, p, gain_db, &mut rng);
    }
    every_copy_is_found(&patterns, &settings, rec, &truth, 8);
}

/// Issue: exact copies are found once each. Three voices' words, as the exact-copy
/// protocol cuts them (from where the waveform first reaches 5 % of its peak), copied
/// at -12..0 dB in noise 50 dB down. A copy of "shot" ends on its "t", 0.28 s after its
/// onset and out of the silence of its closure: that "t" scored 0.59 as a "tick" and
/// fired, as the take's own later window there, though it resembled the sound better
/// than any pattern's take did, resembled it under the 0.8 the continuation asked.
#[test]
fn an_exact_copy_whose_later_sound_rises_out_of_its_soft_start_fires_once() {
    let dir = temp_dir("copies-once");
    let settings = spectral();
    let words = [
        ("fish", "en-us-nyc+david"),
        ("shot", "en-gb-x-gbcwmd+steph"),
        ("tick", "en+Antonio"),
    ];
    let patterns: Vec<Pattern> = words
        .iter()
        .map(|(name, voice)| {
            let said = word_by(&dir, name, name, voice, "175");
            let peak = said.iter().fold(0.0f32, |m, v| m.max(v.abs()));
            let first = said.iter().position(|v| v.abs() > 0.05 * peak).unwrap();
            let last = said.iter().rposition(|v| v.abs() > 0.05 * peak).unwrap();
            let take = said[first..=last].to_vec();
            Pattern::from_samples(name, PatternKind::Impulse, vec![take], &settings).unwrap()
        })
        .collect();
    let mut rng = Rng::new(11);
    let mut rec = vec![0.0f32; samples_for(0.3, RATE)];
    let mut truth = Vec::new();
    for copy in 0..36 {
        let gain_db = rng.range(-12.0, 0.0);
        let p = &patterns[copy % patterns.len()];
        append_copy(&mut rec, &mut truth, p, gain_db, &mut rng);
    }
    every_copy_is_found(&patterns, &settings, rec, &truth, 12);
}

/// Issue: the paper's own use, words said on a melody's rhythm (its rain scene). The
/// voice's "tick", "pop" and "boom" said quickly (espeak-ng at 300 words a minute) on
/// quarter and eighth notes at 150 bpm, at -6..0 dB: at least 95% F1.
#[test]
fn words_said_on_a_rhythm_at_150_bpm_are_each_found() {
    let (f1, account) = said_on_the_tune("rhythm", "300", 2, 41);
    assert!(f1 >= 0.95, "F1 {f1:.3}: {account}");
}

/// The voice's "tick", "pop" and "boom" (enrolled, and said at `speed` words a minute
/// on the beats of a tune, 1 a quarter note, at 150 bpm, `times` over, each at -6..0 dB
/// drawn from `seed`, in quiet noise): the patterns, the recording and its truth.
struct Tune {
    settings: DetectorSettings,
    patterns: Vec<Pattern>,
    rec: Vec<f32>,
    truth: Vec<(&'static str, f64)>,
}

fn tune(name: &str, speed: &str, times: usize, seed: u64) -> Tune {
    let dir = temp_dir(name);
    let settings = spectral();
    let patterns = without(impulses(enrolled_words(&dir, &settings)), "pew");
    let names = ["tick", "pop", "boom"];
    let said: Vec<Vec<f32>> = names
        .iter()
        .map(|n| word(&dir, &format!("{n}-{speed}"), n, speed))
        .collect();
    let beats = [
        1.0, 0.5, 0.5, 1.0, 0.5, 0.5, 1.0, 1.0, 0.5, 0.5, 0.5, 0.5, 2.0,
    ];
    let beat_seconds = 60.0 / 150.0;
    let mut rng = Rng::new(seed);
    let mut at = 0.5;
    let mut placements = Vec::new();
    for b in std::iter::repeat_n(&beats, times).flatten() {
        let which = (rng.next_u64() % names.len() as u64) as usize;
        placements.push((which, at, 10f32.powf(rng.range(-6.0, 0.0) as f32 / 20.0)));
        at += b * beat_seconds;
    }
    let mut rec = vec![0.0f32; samples_for(at + 1.0, RATE)];
    let mut truth = Vec::new();
    for (which, at, gain) in placements {
        place(&mut rec, &said[which], samples_for(at, RATE), gain);
        truth.push((names[which], at));
    }
    add_noise(&mut rec, 0.0005, seed + 1);
    Tune {
        settings,
        patterns,
        rec,
        truth,
    }
}

/// The F1 of what the detector finds in [`tune`]'s recording, and its account with the
/// explanation of every onset.
fn said_on_the_tune(name: &str, speed: &str, times: usize, seed: u64) -> (f64, String) {
    let t = tune(name, speed, times, seed);
    let mut det = Detector::new(t.patterns, &t.settings, RATE).unwrap();
    det.enable_explain();
    let events = detect_in_blocks(&mut det, &t.rec, 256);
    let (f1, account) = f1_against(&events, &t.truth);
    (f1, format!("{account}\n{}", explained(&mut det)))
}

/// A word judged over a fired word's tail waits for a second decision window: the
/// words of the tune at their own speed give the same events in blocks of any size,
/// some fired so, and every decision within the detector's decision delay bound.
#[test]
fn words_judged_over_a_tail_ignore_block_size_and_stay_within_the_bound() {
    let t = tune("rhythm-blocks", "160", 3, 45);
    let run = |block: usize| {
        let mut det = Detector::new(t.patterns.clone(), &t.settings, RATE).unwrap();
        det.enable_explain();
        let events = detect_in_blocks(&mut det, &t.rec, block);
        let records = det.take_explain().unwrap_or_default();
        (events, records, det.decision_delay_bound())
    };
    let (events, records, bound) = run(256);
    // Onsets over a tail that waited for their second window, and those that fired.
    let waited: Vec<_> = records
        .iter()
        .filter(|r| r.explained_over_tail.is_some() && r.window_seconds.is_some_and(|w| w > 0.03))
        .collect();
    let fired = waited
        .iter()
        .filter(|r| r.outcome == onomato::detect::gates::Outcome::Fired)
        .count();
    assert!(
        waited.len() >= 3 && fired >= 1,
        "{} waited, {fired} fired",
        waited.len()
    );
    for e in &events {
        assert!(e.emitted_at - e.time <= bound, "{e:?}, bound {bound}");
    }
    for block in [1, 7, 4096] {
        assert_eq!(run(block).0, events, "blocks of {block}");
    }
}

/// Issue: in the paper's rhythm the words overlap: each begins while the one before
/// still sounds, so it does not rise out of quiet. Pairs of the voice's words, the
/// second said 0.2 s after a short first one ("tick" or "pop", eighth notes at 150
/// bpm, the words at about their enrolled speed, so the first has not died away): both
/// are found, and the second fires over the first's tail although it rose less than
/// the quiet-before gate asks.
#[test]
fn a_word_said_over_the_tail_of_a_word_that_fired_is_found() {
    let dir = temp_dir("overlap");
    let settings = spectral();
    let patterns = without(impulses(enrolled_words(&dir, &settings)), "pew");
    let names = ["tick", "pop", "boom"];
    let said: Vec<Vec<f32>> = names
        .iter()
        .map(|n| word(&dir, &format!("{n}-said"), n, "160"))
        .collect();
    let pairs = [(0, 1), (1, 0), (0, 2), (1, 2), (0, 0), (1, 1)];
    let mut rec = vec![0.0f32; samples_for(0.5 + pairs.len() as f64 + 1.0, RATE)];
    let mut truth = Vec::new();
    for (i, &(first, second)) in pairs.iter().enumerate() {
        let at = 0.5 + i as f64;
        for (which, at) in [(first, at), (second, at + 0.2)] {
            place(&mut rec, &said[which], samples_for(at, RATE), 0.7);
            truth.push((names[which], at));
        }
    }
    add_noise(&mut rec, 0.0005, 43);
    let mut det = Detector::new(patterns, &settings, RATE).unwrap();
    det.enable_explain();
    let events = detect_in_blocks(&mut det, &rec, 256);
    let (f1, account) = f1_against(&events, &truth);
    let records = det.take_explain().unwrap_or_default();
    let mut table = Vec::new();
    onomato::analyze::write_explain(&mut table, &records).unwrap();
    let table = String::from_utf8(table).unwrap();
    assert!(f1 >= 0.95, "F1 {f1:.3}: {account}\n{table}");
    let over_a_tail = records
        .iter()
        .filter(|r| {
            r.outcome == onomato::detect::gates::Outcome::Fired
                && r.over_fired_impulse
                && r.rise_db.is_some_and(|rise| rise < 10.0)
        })
        .count();
    assert!(
        over_a_tail >= 2,
        "{over_a_tail} words fired over a word's tail without rising 10 dB:\n{table}"
    );
}

/// Issue: the paper's rhythm with the words said at their enrolled speed: each begins
/// while the one before still sounds, so its first window is mostly the last word's
/// tail. The voice's "tick", "pop" and "boom" at 160 words a minute on the tune above,
/// three times over: at least 0.58 F1 (0.61 now; 0.56 when whether such a word was
/// the last one's own later sound was judged by the similarity of its features, which
/// are mostly that word's tail; 0.41 when such a word was judged by how its first
/// window matched alone). Not yet the 0.95: words 0.2 s into a "boom" begin
/// over its vowel at full level, and once one word is missed the next begin over
/// sound no pattern recognised (a "pop" whose take explains 0.84 of its two windows,
/// under the 0.85 asked, takes the three "tick"s after it along).
#[test]
fn words_said_at_their_own_speed_on_a_rhythm_at_150_bpm_are_found() {
    let (f1, account) = said_on_the_tune("rhythm-overlap", "160", 3, 45);
    assert!(f1 >= 0.58, "F1 {f1:.3}: {account}");
}

/// Issue: a voice whose "p" lasts nearly as long as the wait (espeak-ng's at 130 words a
/// minute: "pop" and "pew" alike 1.00, 1.00 and 0.76 over one, two and three decision
/// windows) never fell under the similarity at which a pair counts as parted, so it
/// never waited, and one was taken for the other (on an unheard voice, 24 of 50). Such
/// a pair now waits for the windows that part it most: said alone three times each at
/// 120 words a minute and at several levels, each is found as itself.
#[test]
fn pop_and_pew_whose_p_lasts_as_long_as_the_wait_are_told_apart() {
    let dir = temp_dir("pop-pew-slow");
    let settings = spectral();
    let patterns = impulses(enrolled_words_at(&dir, &settings, "130"));
    let pairs = onomato::pattern::takes_report(&patterns, &settings)
        .unwrap()
        .look_alike;
    let pair = pairs
        .iter()
        .find(|p| p.involves("pop") && p.involves("pew"))
        .unwrap_or_else(|| panic!("pop and pew not alike: {pairs:?}"));
    assert!(pair.decided_after_seconds.is_some(), "no wait: {pair}");
    said_alone_are_found(
        &dir,
        &patterns,
        &settings,
        &["pop", "pew"],
        11,
        "120",
        as_made,
    );
}

/// Issue: "pew", whose attack is soft and voiced in some voices, was never found. Said
/// alone three times at another speed and at several levels, with "pop" (the same
/// burst, see above) not enrolled, it is found.
#[test]
fn a_soft_attack_pew_said_alone_is_found() {
    let dir = temp_dir("pew");
    let settings = spectral();
    let patterns = without(enrolled_words(&dir, &settings), "pop");
    said_alone_are_found(&dir, &patterns, &settings, &["pew"], 7, "140", as_made);
}

/// Issue: "pop" and "pew" of one voice share their first 25 ms (the "p" and its
/// release), so one decision window cannot tell them apart and one was taken for the
/// other. Enrolment finds such a pair, and a choice between them waits for their
/// vowels: said alone three times each at another speed and level, each is found as
/// itself.
#[test]
fn pop_and_pew_which_share_their_first_25_ms_are_told_apart() {
    let dir = temp_dir("pop-pew");
    let settings = spectral();
    let patterns = impulses(enrolled_words(&dir, &settings));
    // `check` says so, and how long a decision between them waits.
    let pairs = onomato::pattern::takes_report(&patterns, &settings)
        .unwrap()
        .look_alike;
    let pair = pairs
        .iter()
        .find(|p| p.involves("pop") && p.involves("pew"))
        .unwrap_or_else(|| panic!("pop and pew not alike: {pairs:?}"));
    let after = pair.decided_after_seconds.expect("pop and pew part later");
    assert!(
        after > settings.decision_seconds && after <= settings.max_decision_seconds + 1e-9,
        "{pair}"
    );
    said_alone_are_found(
        &dir,
        &patterns,
        &settings,
        &["pop", "pew"],
        9,
        "140",
        as_made,
    );
}

/// A held sound that the speech guard stopped (it follows other talking) is still the
/// pattern's sound for as long as it goes on, not only for its take's length: a "hooo"
/// said three times as long as enrolled, after a word that is none of the patterns, must
/// not keep the guard closed over the "tick" said 0.25 s after it.
#[test]
fn a_word_after_a_long_held_sound_the_guard_stopped_is_found() {
    let dir = temp_dir("after-stopped-held");
    let settings = spectral();
    let patterns = enrolled_words(&dir, &settings);
    let talking = word(&dir, "talking", "seven", "175");
    word(&dir, "long-hooo-take", "hoooooo", "175");
    let long = dir.join("long-hooo.wav");
    #[rustfmt::skip]
    run("sox", &[dir.join("long-hooo-take.wav").to_str().unwrap(), long.to_str().unwrap(), "tempo", "0.33"]);
    let hooo = read(&long);
    let tick = word(&dir, "tick-after", "tick", "175");
    let mut rec = vec![0.0f32; samples_for(0.3, RATE)];
    rec.extend(&talking);
    rec.extend(vec![0.0; samples_for(0.05, RATE)]);
    let hooo_onset = rec.len() as f64 / f64::from(RATE);
    rec.extend(&hooo);
    rec.extend(vec![0.0; samples_for(0.25, RATE)]);
    let onset = rec.len() as f64 / f64::from(RATE);
    rec.extend(&tick);
    rec.extend(vec![0.0; samples_for(0.5, RATE)]);
    add_noise(&mut rec, 0.0005, 29);
    let mut det = Detector::new(patterns, &settings, RATE).unwrap();
    det.enable_explain();
    let events = detect_in_blocks(&mut det, &rec, 256);
    assert!(
        events
            .iter()
            .any(|e| &*e.pattern == "tick" && (e.time - onset).abs() <= 0.05),
        "tick at {onset:.3} (hooo from {hooo_onset:.3}, {:.2} s): {:?}\n{}",
        hooo.len() as f64 / f64::from(RATE),
        events
            .iter()
            .map(|e| format!("{} {:.3}", e.pattern, e.time))
            .collect::<Vec<_>>(),
        explained(&mut det)
    );
}

/// A voice's own stressed syllable after a pause begins as one of its words does, and
/// no talk closes the guard on it. Said inside the voice's talk, with talk after it as
/// well as before, the same syllable was heard as talk: said again after a pause, it is
/// talk, not the word. Each syllable the guard stopped inside the talk is cut out and
/// said again, once after a second of quiet alone (where those that fire show it is a
/// sound the words are taken for) and once a second after the talk.
#[test]
fn a_syllable_of_the_voices_own_talk_said_again_after_a_pause_is_talk_not_its_word() {
    use onomato::detect::gates::Outcome;
    let dir = temp_dir("own-talk");
    let settings = spectral();
    let voice = "en-029+Marco";
    let patterns: Vec<Pattern> = ["tick", "pop", "pew", "boom"]
        .iter()
        .map(|name| {
            let take = word_by(&dir, name, name, voice, "175");
            Pattern::from_samples(name, PatternKind::Impulse, vec![take], &settings).unwrap()
        })
        .collect();
    let path = dir.join("talk.wav");
    let text = root().join("tests/data/speech-paragraph.txt");
    #[rustfmt::skip]
    run("espeak-ng", &["-v", voice, "-s", "165", "-p", "50", "-w", path.to_str().unwrap(), "-f", text.to_str().unwrap()]);
    let talk = read(&path);
    let run_on = |rec: &[f32]| {
        let mut rec = rec.to_vec();
        add_noise(&mut rec, 0.0005, 31);
        let mut det = Detector::new(patterns.clone(), &settings, RATE).unwrap();
        det.enable_explain();
        let events = detect_in_blocks(&mut det, &rec, 256);
        (events, det.take_explain().unwrap_or_default())
    };
    let (_, records) = run_on(&talk);
    let stopped: Vec<f64> = records
        .iter()
        .filter(|r| r.outcome == Outcome::SpeechGuard && r.best.is_some())
        .map(|r| r.time)
        .collect();
    let pause = samples_for(1.0, RATE);
    let mut fired_alone = 0;
    for &at in &stopped {
        // From 20 ms before its onset, faded in over 15 ms, to 350 ms after it.
        let from = samples_for(at - 0.02, RATE);
        let mut syllable = talk[from..(from + samples_for(0.37, RATE)).min(talk.len())].to_vec();
        let fade = samples_for(0.015, RATE);
        for (i, x) in syllable.iter_mut().take(fade).enumerate() {
            *x *= i as f32 / fade as f32;
        }
        let again = |before: &[f32]| {
            let mut rec = before.to_vec();
            rec.extend(vec![0.0; pause]);
            let said = rec.len() as f64 / f64::from(RATE) + 0.02;
            rec.extend(&syllable);
            rec.extend(vec![0.0; samples_for(0.5, RATE)]);
            let (events, records) = run_on(&rec);
            let fired: Vec<String> = events
                .iter()
                .filter(|e| e.time > said - 0.05)
                .map(|e| format!("{} {:.3}", e.pattern, e.time))
                .collect();
            let onset = records
                .into_iter()
                .filter(|r| (r.time - said).abs() <= 0.03)
                .min_by(|a, b| (a.time - said).abs().total_cmp(&(b.time - said).abs()));
            (fired, onset)
        };
        if again(&[]).0.is_empty() {
            continue;
        }
        fired_alone += 1;
        let (fired, onset) = again(&talk);
        assert!(
            fired.is_empty()
                && onset
                    .as_ref()
                    .is_some_and(|r| r.outcome == Outcome::Background
                        && r.because_of.is_some_and(|s| s.from < at + 0.5)),
            "the syllable of {at:.3} s, said again after the talk: fired {fired:?}, {onset:#?}"
        );
    }
    assert!(
        fired_alone > 0,
        "none of the {} syllables the guard stopped fires alone: nothing tested",
        stopped.len()
    );
}
