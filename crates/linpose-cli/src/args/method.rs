//! The method flags of `linpose train`, made from the method registry: every setting a method
//! declares ([`linpose::Method::options`]) is a flag of the same name, its help naming the
//! methods that take it. What the user gave becomes [`linpose::Settings`], which the chosen
//! method reads (refusing a flag meant for another method).

use clap::parser::ValueSource;
use clap::{Arg, ArgAction, ArgMatches, Args, Command, FromArgMatches};
use linpose::{Method, Settings, METHODS};

/// One flag: a setting's name and value name, with the methods that declare it and their help.
struct Flag {
    name: &'static str,
    value: &'static str,
    help: Vec<(&'static Method, &'static str)>,
}

/// Each setting name once.
fn flags() -> Vec<Flag> {
    let mut out: Vec<Flag> = Vec::new();
    for &m in METHODS {
        for o in m.options {
            match out.iter_mut().find(|f| f.name == o.name) {
                Some(f) => f.help.push((m, o.help)),
                None => out.push(Flag { name: o.name, value: o.value, help: vec![(m, o.help)] }),
            }
        }
    }
    out
}

/// The method flags given on the command line.
#[derive(Debug, Clone, Default)]
pub(crate) struct MethodArgs {
    /// The settings, named as the flags without their dashes.
    pub settings: Settings,
}

impl FromArgMatches for MethodArgs {
    fn from_arg_matches(m: &ArgMatches) -> Result<Self, clap::Error> {
        let mut s = Self::default();
        s.update_from_arg_matches(m)?;
        Ok(s)
    }

    fn update_from_arg_matches(&mut self, m: &ArgMatches) -> Result<(), clap::Error> {
        for f in flags() {
            if m.value_source(f.name) != Some(ValueSource::CommandLine) {
                continue;
            }
            let v = if f.value.is_empty() { "true".to_string() } else { m.get_one::<String>(f.name).cloned().unwrap_or_default() };
            self.settings = std::mem::take(&mut self.settings).set(f.name, v);
        }
        Ok(())
    }
}

impl Args for MethodArgs {
    fn augment_args(mut cmd: Command) -> Command {
        for f in flags() {
            let help = f.help.iter().map(|(m, h)| format!("{}: {h}", capitalised(m.name))).collect::<Vec<_>>().join(". ");
            let arg = Arg::new(f.name).long(f.name).help(help).help_heading("Method settings");
            cmd = cmd.arg(if f.value.is_empty() {
                arg.action(ArgAction::SetTrue)
            } else {
                arg.value_name(f.value).action(ArgAction::Set).allow_negative_numbers(true)
            });
        }
        cmd
    }

    fn augment_args_for_update(cmd: Command) -> Command {
        Self::augment_args(cmd)
    }
}

fn capitalised(s: &str) -> String {
    let mut c = s.chars();
    c.next().map(|f| f.to_uppercase().chain(c).collect()).unwrap_or_default()
}

/// The registry's method names as clap's possible values, each with its summary.
pub(crate) fn method_names() -> clap::builder::PossibleValuesParser {
    clap::builder::PossibleValuesParser::new(METHODS.iter().map(|m| clap::builder::PossibleValue::new(m.name).help(m.summary)))
}

/// The method called `name` (one of [`method_names`]).
pub(crate) fn method(name: &str) -> &'static Method {
    linpose::Method::from_name(name).expect("clap checked the name against the registry")
}

/// A library error about a setting, said as the flag that gave it.
pub(crate) fn as_flag(e: linpose::Error) -> anyhow::Error {
    match e {
        linpose::Error::Setting { name, value, reason, .. } if value == "true" => anyhow::anyhow!("--{name}: {reason}"),
        linpose::Error::Setting { name, value, reason, .. } => anyhow::anyhow!("--{name} {value}: {reason}"),
        e => e.into(),
    }
}
