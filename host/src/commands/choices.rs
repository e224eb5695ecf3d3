//! The words a user chooses among, as the command line's flags take them
//! and the Python package's keyword arguments too (`--prior-scale chosen`,
//! `prior_scale="chosen"`): one `clap::ValueEnum` each, with the library's
//! type it names. The command line parses them with clap; Python with
//! [`parse`], which refuses a word with the same list of words clap gives.

use armcal_shared::TargetFrame;
use clap::ValueEnum;

use crate::calibration::gravity::TorqueSign;
use crate::calibration::identify::ParamSet;
use crate::calibration::identify::channel_weight::ChannelWeight;
use crate::calibration::identify::prior_scale::PriorScale;
use crate::calibration::plan::design::Optimality;

/// The choice named `word` (`"chosen"`, `"0.1"`, …), or why not: `"WORD":
/// expected "a", "b" or "c"`, the words in the order `--help` lists them.
pub fn parse<T: ValueEnum>(word: &str) -> Result<T, String> {
    T::from_str(word, false).map_err(|_| expected(word, &words::<T>()))
}

/// The words of choice `T`, each quoted, in the order `--help` lists them.
pub fn words<T: ValueEnum>() -> Vec<String> {
    T::value_variants()
        .iter()
        .filter_map(|v| v.to_possible_value())
        .map(|v| format!("{:?}", v.get_name()))
        .collect()
}

/// Why `word` is refused: `"WORD": expected a, b or c`.
pub fn expected(word: &str, words: &[String]) -> String {
    let listed = match words.split_last() {
        Some((last, [])) => last.clone(),
        Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
        None => String::new(),
    };
    format!("{word:?}: expected {listed}")
}

/// `--criterion`.
#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub enum CriterionArg {
    /// The calibrated robot's predicted error over the workspace.
    IOptimal,
    /// The volume of the parameters' confidence region.
    DOptimal,
}

impl From<CriterionArg> for Optimality {
    fn from(a: CriterionArg) -> Self {
        match a {
            CriterionArg::IOptimal => Optimality::I,
            CriterionArg::DOptimal => Optimality::D,
        }
    }
}

/// `--torque-sign`, `torque_sign=`: the sign of the `tau` columns.
#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub enum TorqueSignArg {
    /// The torque each drive exerts on its link (armcal's tau).
    Drive,
    /// The load torque the joints' sensors read (the drive's negated).
    Load,
}

impl From<TorqueSignArg> for TorqueSign {
    fn from(a: TorqueSignArg) -> Self {
        match a {
            TorqueSignArg::Drive => TorqueSign::Drive,
            TorqueSignArg::Load => TorqueSign::Load,
        }
    }
}

/// `--prior-scale`, `prior_scale=`: the prior's scale as stated or chosen.
#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub enum PriorScaleArg {
    /// The stated scale times the factor that predicts held-out poses best.
    Chosen,
    /// The stated scale.
    Stated,
}

impl From<PriorScaleArg> for PriorScale {
    fn from(a: PriorScaleArg) -> Self {
        match a {
            PriorScaleArg::Chosen => PriorScale::default(),
            PriorScaleArg::Stated => PriorScale::Stated,
        }
    }
}

/// `--orientation-weight`, `--point-weight`, `--plane-weight` and their
/// keywords: a kind of row's weight.
#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub enum WeightArg {
    /// The weight that predicts held-out tool points best.
    Chosen,
    /// As the noise gives it.
    Estimated,
    /// A tenth of it.
    #[value(name = "0.1")]
    Tenth,
    /// A hundredth of it.
    #[value(name = "0.01")]
    Hundredth,
    /// Not used: the geometry from the other rows.
    None,
}

impl From<WeightArg> for ChannelWeight {
    fn from(a: WeightArg) -> Self {
        match a {
            WeightArg::Chosen => ChannelWeight::default(),
            WeightArg::Estimated => ChannelWeight::Stated(1.0),
            WeightArg::Tenth => ChannelWeight::Stated(0.1),
            WeightArg::Hundredth => ChannelWeight::Stated(0.01),
            WeightArg::None => ChannelWeight::Stated(0.0),
        }
    }
}

/// `--params`, `params=`: the model identified.
#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub enum Params {
    /// Every identifiable geometric parameter, base and tool included.
    Full,
    /// The 3M position-independent model of Mirman & Gupta.
    Paper,
}

impl From<Params> for ParamSet {
    fn from(p: Params) -> Self {
        match p {
            Params::Full => ParamSet::Full,
            Params::Paper => ParamSet::Paper,
        }
    }
}

/// `--targets`, `targets=`: the frame compensation targets are given in.
#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub enum Targets {
    /// The world (measurement) frame.
    World,
    /// The robot's own base frame.
    Base,
}

impl From<Targets> for TargetFrame {
    fn from(t: Targets) -> Self {
        match t {
            Targets::World => TargetFrame::World,
            Targets::Base => TargetFrame::Base,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_word_is_its_choice_and_another_is_refused_with_the_words() {
        assert!(matches!(
            parse::<PriorScaleArg>("stated"),
            Ok(PriorScaleArg::Stated)
        ));
        assert!(matches!(
            parse::<WeightArg>("0.01"),
            Ok(WeightArg::Hundredth)
        ));
        assert_eq!(
            parse::<WeightArg>("half").unwrap_err(),
            r#""half": expected "chosen", "estimated", "0.1", "0.01" or "none""#
        );
        assert_eq!(
            parse::<Targets>("tool").unwrap_err(),
            r#""tool": expected "world" or "base""#
        );
    }
}
