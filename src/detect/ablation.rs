//! Switches that turn one mechanism of the spectral matcher off, to measure what each
//! contributes over every protocol (`scripts/ablation.sh`). Read once, when a matcher
//! is built (on the thread that builds it), from the `ONOMATO_ABLATE` environment
//! variable (names separated by commas), and only in a build with the `ablation`
//! feature: in every other build each mechanism is on and nothing is read.

/// Which mechanisms are off. `Default`: none.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(super) struct Ablation {
    /// The quiet-before gate (and with it both of its exceptions below).
    pub quiet_before: bool,
    /// Its exception for a clear impulse over a fired word's tail (`over_fired_score`).
    pub over_fired: bool,
    /// Its exception for what a take adds to a fired word's tail, and the two windows
    /// such an onset is judged over.
    pub over_tail: bool,
    /// The speech guard's gate (its span still counts as talk for the other stages).
    pub speech_guard: bool,
    /// A stopped sound that its pattern named counted as a pattern's sound.
    pub cover_stopped: bool,
    /// The continuation gate: the last impulse's own later sound.
    pub continuation: bool,
    /// The last impulse's attack after the soft start it fired on.
    pub soft_start_attack: bool,
    /// A sound of one sound repeated followed as one event.
    pub repeated: bool,
    /// The background stage (and so the second look).
    pub background: bool,
    /// The second look at what the background took.
    pub second_look: bool,
    /// The `min_strength` gate.
    pub min_strength: bool,
    /// Pairs alike over one window decided over the windows that part them.
    pub pair_waits: bool,
    /// An instance between two patterns decided over two windows.
    pub between_two: bool,
    /// The copies stage (exact copies found by their waveform).
    pub copies: bool,
    /// Tracking and the kept instances: the takes alone are compared.
    pub tracking: bool,
    /// An impulse found by its take's later placement dated at the earlier.
    pub dated_back: bool,
    /// A second placement of each take (an impulse's in a quiet room, a held sound's
    /// soft start) enrolled.
    pub second_placement: bool,
    /// The same attack found twice is dropped (unscored; or once dated back onto it).
    pub same_onset: bool,
    /// The talk heard lately (the sounds the guard stopped amid talk) compared as
    /// background.
    pub heard_talk: bool,
}

/// Every switch's name, in the order of the fields.
#[cfg_attr(not(feature = "ablation"), allow(dead_code))]
pub(super) const NAMES: [&str; 19] = [
    "quiet_before",
    "over_fired",
    "over_tail",
    "speech_guard",
    "cover_stopped",
    "continuation",
    "soft_start_attack",
    "repeated",
    "background",
    "second_look",
    "min_strength",
    "pair_waits",
    "between_two",
    "copies",
    "tracking",
    "dated_back",
    "second_placement",
    "same_onset",
    "heard_talk",
];

impl Ablation {
    #[cfg_attr(not(feature = "ablation"), allow(dead_code))]
    /// The switches named in `list` (comma-separated; blanks ignored) turned off.
    pub fn parse(list: &str) -> Result<Self, String> {
        let mut off = Self::default();
        for name in list.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let field = match name {
                "quiet_before" => &mut off.quiet_before,
                "over_fired" => &mut off.over_fired,
                "over_tail" => &mut off.over_tail,
                "speech_guard" => &mut off.speech_guard,
                "cover_stopped" => &mut off.cover_stopped,
                "continuation" => &mut off.continuation,
                "soft_start_attack" => &mut off.soft_start_attack,
                "repeated" => &mut off.repeated,
                "background" => &mut off.background,
                "second_look" => &mut off.second_look,
                "min_strength" => &mut off.min_strength,
                "pair_waits" => &mut off.pair_waits,
                "between_two" => &mut off.between_two,
                "copies" => &mut off.copies,
                "tracking" => &mut off.tracking,
                "dated_back" => &mut off.dated_back,
                "second_placement" => &mut off.second_placement,
                "same_onset" => &mut off.same_onset,
                "heard_talk" => &mut off.heard_talk,
                other => {
                    return Err(format!(
                        "ONOMATO_ABLATE: no mechanism {other:?}; expected some of {}",
                        NAMES.join(", ")
                    ))
                }
            };
            *field = true;
        }
        Ok(off)
    }

    /// What `ONOMATO_ABLATE` turns off. A measurement build only: a name it does not
    /// know stops the program, naming the variable and the names it knows.
    #[cfg(feature = "ablation")]
    pub fn from_env() -> Self {
        match std::env::var("ONOMATO_ABLATE") {
            Ok(list) => Self::parse(&list).unwrap_or_else(|e| panic!("{e}")),
            Err(_) => Self::default(),
        }
    }

    /// Every mechanism on.
    #[cfg(not(feature = "ablation"))]
    pub fn from_env() -> Self {
        Self::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_name_turns_its_own_switch_off_and_an_unknown_one_is_named() {
        assert_eq!(Ablation::parse(""), Ok(Ablation::default()));
        let mut seen = Vec::new();
        for name in NAMES {
            let off = Ablation::parse(name).unwrap();
            assert_ne!(off, Ablation::default(), "{name}");
            assert!(!seen.contains(&off), "{name} turns off what another does");
            seen.push(off);
        }
        let two = Ablation::parse(" copies, tracking ").unwrap();
        assert!(two.copies && two.tracking && !two.background);
        let err = Ablation::parse("copies,trackin").unwrap_err();
        assert!(
            err.contains("\"trackin\"") && err.contains("tracking"),
            "{err}"
        );
    }
}
