//! The gates stage: what becomes of a classified onset. Every onset the spectral
//! matcher considers gets one [`Outcome`], decided here from the evidence the other
//! stages gathered about it ([`Evidence`]), by the first gate in order that stops it;
//! an onset no gate stops fires. A pure function, so each gate can be tested alone;
//! runs on the detector thread.

use serde::Serialize;

/// What became of an onset, and which gate decided it (`analyze --explain`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Outcome {
    Fired,
    /// The 5-40 ms before the onset were within `pre_quiet_db` of its peak: it
    /// continues a sound (a consonant after a vowel). Not asked of an impulse that
    /// scores `over_fired_score`, or whose takes explain `over_tail_share` of its
    /// sound, over the tail of an impulse that fired.
    QuietBefore,
    /// The speech guard: it follows unrecognised sound.
    SpeechGuard,
    /// The last impulse's own later sound (the closing "p" of a "pop", or its attack
    /// after the soft start it fired on).
    Continuation,
    /// No pattern scored its threshold: none of the patterns.
    BelowThreshold,
    /// Nearer to ordinary speech (the built-in background) than to its pattern.
    Background,
    /// A held sound of the same pattern goes on.
    HeldContinues,
    /// Quieter than `min_strength` times the take.
    MinStrength,
    /// Placed within the onset stage's shortest gap of the last onset that fired: the
    /// same attack found twice (not scored).
    SameOnset,
    /// Fired later, by its waveform: the sound of an onset that did not fire is one of
    /// the takes, sample for sample (the copies stage, `src/detect/copies.rs`). A second
    /// record of that onset, dated where the take's onset falls.
    Copy,
    /// Fired later: the background took it for speech, but its sound fell away unvoiced
    /// after it, as a hit's does and a syllable's, which runs into its vowel, does not
    /// (the syllable stage, `src/detect/syllable.rs`). A second record of that onset.
    FellAway,
}

impl Outcome {
    pub fn as_str(self) -> &'static str {
        match self {
            Outcome::Fired => "fired",
            Outcome::QuietBefore => "quiet_before",
            Outcome::SpeechGuard => "speech_guard",
            Outcome::Continuation => "continuation",
            Outcome::BelowThreshold => "below_threshold",
            Outcome::Background => "background",
            Outcome::HeldContinues => "held_continues",
            Outcome::MinStrength => "min_strength",
            Outcome::SameOnset => "same_onset",
            Outcome::Copy => "copy",
            Outcome::FellAway => "fell_away",
        }
    }
}

/// The gates' settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GateParams {
    /// A sound must rise this far (dB) above the 5-40 ms before its onset...
    pub pre_quiet_db: f32,
    /// ...unless those 5-40 ms lie in an impulse that fired (a word of a quick rhythm
    /// begins over the tail of the word before) and its best pattern, an impulse,
    /// scores at least this. The gate is there to keep the consonants inside
    /// unrecognised sound (speech) out; over a recognised word it would stop every
    /// word said before the last one died away. An onset inside a word or a hit
    /// matches the patterns less well than a new word does, and a held pattern's
    /// sound is what a word's vowel is made of, so only clear impulses qualify. The
    /// sweep and the scores behind it: `docs/quiet-before.md`.
    pub over_fired_score: f32,
    /// ...or one of its takes, added to that tail, explains at least this share of
    /// the onset's sound that the tail alone leaves unexplained, over each of its first
    /// two decision windows (`share_explained_over_tail` in the classification stage,
    /// `OVER_TAIL_WINDOWS` in the matcher). The onset's
    /// features are then mostly the tail's: such an onset is named by that share, and
    /// neither the threshold nor the background, which judge those features, stops it.
    /// Swept in `docs/quiet-before.md` ("What a take adds to the tail").
    pub over_tail_share: f32,
    /// A sound whose nearest background sound scores this much more than its best
    /// pattern is taken for speech (`docs/background.md`).
    pub background_margin: f32,
    /// Amplitude against the best pattern's take below which a sound is not the user's.
    pub min_strength: f64,
}

impl Default for GateParams {
    fn default() -> Self {
        Self {
            pre_quiet_db: 10.0,
            over_fired_score: 0.95,
            over_tail_share: 0.85,
            background_margin: 0.07,
            min_strength: 0.06,
        }
    }
}

/// What the stages found out about one onset.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Evidence {
    /// The sound's peak over the 5-40 ms before its onset, dB.
    pub rise_db: f32,
    /// Some of those 5-40 ms lie in an impulse that fired.
    pub over_fired_impulse: bool,
    /// The speech guard's span before the onset held enough unrecognised sound.
    pub follows_unrecognised_sound: bool,
    /// It is the last fired impulse's own later sound (over that impulse's tail, when
    /// named by what a take adds to it: by what the impulse's take adds as much later),
    /// or that impulse's attack after the soft start it fired on.
    pub continues_last_impulse: bool,
    /// The best pattern's score, whether it is an impulse, and its threshold.
    pub best_score: f32,
    pub best_is_impulse: bool,
    /// Over a fired impulse's tail that the onset did not rise out of: the share of
    /// its sound that the pattern's best take explains over the tail (0 otherwise, and
    /// for a clear instance, which its score excuses).
    pub explained_over_tail: f32,
    pub threshold: f32,
    /// The nearest background sound's score (minus infinity without a background).
    pub background_score: f32,
    /// The score of the user's talk heard lately that lies nearest (minus infinity
    /// before any was heard; [`super::talk`]).
    pub talk_score: f32,
    /// A held sound of the best pattern is going on.
    pub held_by_best_pattern: bool,
    /// Amplitude against the best pattern's take.
    pub strength: f64,
}

impl Evidence {
    /// The sound did not rise out of what went before, and that was not a word that
    /// fired with this one a clear instance of an impulse pattern, or what one adds to
    /// that word's tail.
    pub fn continues_a_sound(&self, params: &GateParams) -> bool {
        self.rise_db < params.pre_quiet_db
            && !(self.over_fired_impulse
                && self.best_is_impulse
                && self.best_score >= params.over_fired_score)
            && !self.new_over_tail(params)
    }

    /// An impulse pattern's take added to the tail of a word that fired explains the
    /// sound that did not rise out of that tail.
    pub fn new_over_tail(&self, params: &GateParams) -> bool {
        self.rise_db < params.pre_quiet_db
            && self.over_fired_impulse
            && self.best_is_impulse
            && self.explained_over_tail >= params.over_tail_share
    }

    /// No pattern scored its threshold.
    pub fn below_threshold(&self) -> bool {
        self.best_score < self.threshold
    }

    /// The nearest of the sounds that must never fire: the background and, for an
    /// impulse, the user's own talk heard lately (a held sound's vowel or hiss is in
    /// every talk, a held pattern's among it: [`super::talk`]).
    pub fn speech_score(&self) -> f32 {
        let talk = if self.best_is_impulse {
            self.talk_score
        } else {
            f32::NEG_INFINITY
        };
        self.background_score.max(talk)
    }

    /// The nearest sound that must never fire is the user's own talk (which judges an
    /// impulse pattern's onset alone).
    pub fn by_own_talk(&self) -> bool {
        self.best_is_impulse && self.talk_score > self.background_score
    }

    /// The background, or the user's own talk, explains the sound better than its
    /// pattern.
    pub fn like_speech(&self, params: &GateParams) -> bool {
        self.speech_score() >= self.best_score + params.background_margin
    }
}

/// The first gate, in order, that stops the onset; `Fired` when none does.
pub fn decide(e: &Evidence, params: &GateParams) -> Outcome {
    // The threshold and the background judge the onset's features, which over a
    // word's tail are mostly the tail's.
    let over_tail = e.new_over_tail(params);
    if e.continues_a_sound(params) {
        Outcome::QuietBefore
    } else if e.follows_unrecognised_sound {
        Outcome::SpeechGuard
    } else if e.continues_last_impulse {
        Outcome::Continuation
    } else if e.below_threshold() && !over_tail {
        Outcome::BelowThreshold
    } else if e.like_speech(params) && !over_tail {
        Outcome::Background
    } else {
        after_background(e, params)
    }
}

/// What the gates after the background decide of an onset: those an onset the
/// background took for speech must still pass if it is to fire later (the syllable
/// stage's second look).
pub fn after_background(e: &Evidence, params: &GateParams) -> Outcome {
    if e.held_by_best_pattern {
        Outcome::HeldContinues
    } else if e.strength < params.min_strength {
        Outcome::MinStrength
    } else {
        Outcome::Fired
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An onset that every gate lets through.
    fn clear() -> Evidence {
        Evidence {
            rise_db: 40.0,
            over_fired_impulse: false,
            follows_unrecognised_sound: false,
            continues_last_impulse: false,
            best_score: 0.8,
            best_is_impulse: true,
            explained_over_tail: 0.0,
            threshold: 0.3,
            background_score: 0.5,
            talk_score: f32::NEG_INFINITY,
            held_by_best_pattern: false,
            strength: 1.0,
        }
    }

    #[test]
    fn an_onset_no_gate_stops_fires() {
        assert_eq!(decide(&clear(), &GateParams::default()), Outcome::Fired);
    }

    /// An onset the background took for speech is judged by the gates after it as
    /// `decide` would have judged it without the background.
    #[test]
    fn the_gates_after_the_background_judge_a_sound_it_took_as_without_it() {
        let p = GateParams::default();
        let speech = Evidence {
            background_score: 0.95,
            ..clear()
        };
        assert_eq!(decide(&speech, &p), Outcome::Background);
        assert_eq!(after_background(&speech, &p), Outcome::Fired);
        let faint = Evidence {
            strength: p.min_strength * 0.5,
            ..speech
        };
        assert_eq!(decide(&faint, &p), Outcome::Background);
        assert_eq!(after_background(&faint, &p), Outcome::MinStrength);
        let held = Evidence {
            held_by_best_pattern: true,
            ..speech
        };
        assert_eq!(after_background(&held, &p), Outcome::HeldContinues);
    }

    #[test]
    fn each_gate_stops_an_onset_by_its_own_evidence_and_names_itself() {
        let p = GateParams::default();
        let cases: [(Evidence, Outcome); 8] = [
            (
                Evidence {
                    rise_db: 9.9,
                    ..clear()
                },
                Outcome::QuietBefore,
            ),
            (
                Evidence {
                    follows_unrecognised_sound: true,
                    ..clear()
                },
                Outcome::SpeechGuard,
            ),
            (
                Evidence {
                    continues_last_impulse: true,
                    ..clear()
                },
                Outcome::Continuation,
            ),
            (
                Evidence {
                    best_score: 0.29,
                    ..clear()
                },
                Outcome::BelowThreshold,
            ),
            (
                Evidence {
                    // The background nearer than the pattern by the margin.
                    background_score: clear().best_score + p.background_margin,
                    ..clear()
                },
                Outcome::Background,
            ),
            (
                Evidence {
                    // The user's own talk heard lately, as near.
                    talk_score: clear().best_score + p.background_margin,
                    ..clear()
                },
                Outcome::Background,
            ),
            (
                Evidence {
                    held_by_best_pattern: true,
                    ..clear()
                },
                Outcome::HeldContinues,
            ),
            (
                Evidence {
                    strength: 0.05,
                    ..clear()
                },
                Outcome::MinStrength,
            ),
        ];
        for (e, expected) in cases {
            assert_eq!(decide(&e, &p), expected, "{e:?}");
        }
    }

    /// The talk heard lately is syllables: it judges an impulse pattern's onset, not a
    /// held pattern's vowel or hiss.
    #[test]
    fn the_talk_heard_lately_judges_impulses_alone() {
        let p = GateParams::default();
        let near_talk = Evidence {
            talk_score: clear().best_score + p.background_margin,
            ..clear()
        };
        assert_eq!(decide(&near_talk, &p), Outcome::Background);
        assert!(near_talk.by_own_talk());
        let held = Evidence {
            best_is_impulse: false,
            ..near_talk
        };
        assert_eq!(decide(&held, &p), Outcome::Fired);
        // A held pattern's onset the background took is not named the talk's.
        let held_near_speech = Evidence {
            background_score: held.talk_score,
            talk_score: held.talk_score + 0.05,
            ..held
        };
        assert_eq!(decide(&held_near_speech, &p), Outcome::Background);
        assert!(!held_near_speech.by_own_talk());
    }

    #[test]
    fn over_the_tail_of_a_sound_that_fired_a_clear_impulse_is_excused_the_rise() {
        let p = GateParams::default();
        let over_a_word = Evidence {
            rise_db: 3.0,
            over_fired_impulse: true,
            best_score: 0.97,
            ..clear()
        };
        assert_eq!(decide(&over_a_word, &p), Outcome::Fired);
        for (e, why) in [
            (
                Evidence {
                    over_fired_impulse: false,
                    ..over_a_word
                },
                "over unrecognised sound",
            ),
            (
                Evidence {
                    best_score: 0.94,
                    ..over_a_word
                },
                "not a clear instance",
            ),
            (
                Evidence {
                    best_is_impulse: false,
                    ..over_a_word
                },
                "a held pattern (a word's own vowel)",
            ),
        ] {
            assert_eq!(decide(&e, &p), Outcome::QuietBefore, "{why}: {e:?}");
        }
        // The later gates still judge it.
        let guarded = Evidence {
            follows_unrecognised_sound: true,
            ..over_a_word
        };
        assert_eq!(decide(&guarded, &p), Outcome::SpeechGuard);
    }

    #[test]
    fn over_the_tail_of_a_sound_that_fired_what_a_take_adds_to_it_excuses_the_rise() {
        let p = GateParams::default();
        // Features that no pattern passes and that the background takes for speech:
        // over a tail they are the tail's.
        let over_a_tail = Evidence {
            rise_db: 3.0,
            over_fired_impulse: true,
            best_score: 0.2,
            background_score: 0.9,
            explained_over_tail: 0.9,
            ..clear()
        };
        assert_eq!(decide(&over_a_tail, &p), Outcome::Fired);
        for (e, why) in [
            (
                Evidence {
                    explained_over_tail: 0.84,
                    ..over_a_tail
                },
                "the take explains too little",
            ),
            (
                Evidence {
                    over_fired_impulse: false,
                    ..over_a_tail
                },
                "over unrecognised sound",
            ),
            (
                Evidence {
                    best_is_impulse: false,
                    ..over_a_tail
                },
                "a held pattern",
            ),
        ] {
            assert_eq!(decide(&e, &p), Outcome::QuietBefore, "{why}: {e:?}");
        }
        // A sound that rose out of the tail is judged by its features.
        let rose = Evidence {
            rise_db: 12.0,
            ..over_a_tail
        };
        assert_eq!(decide(&rose, &p), Outcome::BelowThreshold);
        // The gates that do not judge features still do.
        let own_later_sound = Evidence {
            continues_last_impulse: true,
            ..over_a_tail
        };
        assert_eq!(decide(&own_later_sound, &p), Outcome::Continuation);
        let guarded = Evidence {
            follows_unrecognised_sound: true,
            ..over_a_tail
        };
        assert_eq!(decide(&guarded, &p), Outcome::SpeechGuard);
    }

    #[test]
    fn the_first_gate_in_order_names_the_outcome() {
        let p = GateParams::default();
        let everything = Evidence {
            rise_db: 3.0,
            follows_unrecognised_sound: true,
            continues_last_impulse: true,
            best_score: 0.1,
            background_score: 0.9,
            held_by_best_pattern: true,
            strength: 0.0,
            ..clear()
        };
        assert_eq!(decide(&everything, &p), Outcome::QuietBefore);
        let after_quiet = Evidence {
            rise_db: 40.0,
            ..everything
        };
        assert_eq!(decide(&after_quiet, &p), Outcome::SpeechGuard);
        let below = Evidence {
            follows_unrecognised_sound: false,
            continues_last_impulse: false,
            ..after_quiet
        };
        assert_eq!(decide(&below, &p), Outcome::BelowThreshold);
    }

    #[test]
    fn the_margins_are_the_params() {
        let strict = GateParams {
            pre_quiet_db: 20.0,
            over_fired_score: 0.95,
            over_tail_share: 0.85,
            background_margin: 0.5,
            min_strength: 0.0,
        };
        let e = Evidence {
            rise_db: 15.0,
            ..clear()
        };
        assert_eq!(decide(&e, &strict), Outcome::QuietBefore);
        assert_eq!(decide(&e, &GateParams::default()), Outcome::Fired);
        let near_speech = Evidence {
            background_score: 0.9,
            ..clear()
        };
        assert_eq!(
            decide(&near_speech, &GateParams::default()),
            Outcome::Background
        );
        assert_eq!(
            decide(
                &near_speech,
                &GateParams {
                    background_margin: 0.5,
                    ..GateParams::default()
                }
            ),
            Outcome::Fired
        );
        let faint = Evidence {
            strength: 0.01,
            ..clear()
        };
        assert_eq!(decide(&faint, &strict), Outcome::Fired);
    }
}
