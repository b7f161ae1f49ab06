//! The command line's spelling of the library's option names. Library messages name an
//! option between backticks by its keyword (`` `grid_top_density` ``, or with a value
//! `` `levels`=99 ``, see `trace::OptionError`); here every such name that is one of this
//! command line's long options becomes that flag (`--grid-top-density`, `--levels 99`), so
//! only the CLI speaks in flag names. Anything else between backticks (a shell command,
//! say) is left as written.

use clap::CommandFactory;
use std::collections::BTreeSet;
use std::sync::OnceLock;

/// Every long option of every subcommand, without its dashes (`grid-top-density`).
fn flags() -> &'static BTreeSet<String> {
    static FLAGS: OnceLock<BTreeSet<String>> = OnceLock::new();
    FLAGS.get_or_init(|| {
        fn walk(c: &clap::Command, out: &mut BTreeSet<String>) {
            out.extend(
                c.get_arguments()
                    .filter_map(|a| a.get_long())
                    .map(String::from),
            );
            for s in c.get_subcommands() {
                walk(s, out);
            }
        }
        let mut out = BTreeSet::new();
        walk(&super::args::Cli::command(), &mut out);
        out
    })
}

/// `msg` with the library's option names spelled as this command line's flags.
pub fn flags_in(msg: &str) -> String {
    let mut out = String::with_capacity(msg.len());
    let mut rest = msg;
    while let Some(i) = rest.find('`') {
        out += &rest[..i];
        let after = &rest[i + 1..];
        let Some(j) = after.find('`') else {
            out += &rest[i..];
            return out;
        };
        let name = &after[..j];
        let flag = name.replace('_', "-");
        let tail = &after[j + 1..];
        let is_flag = !name.is_empty()
            && name
                .chars()
                .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_')
            && flags().contains(&flag);
        if is_flag {
            out += "--";
            out += &flag;
            // `name`=value is the option with its value: `--name value`.
            rest = match tail.strip_prefix('=') {
                Some(t) => {
                    out.push(' ');
                    t
                }
                None => tail,
            };
        } else {
            out += &rest[i..i + 1 + j + 1];
            rest = tail;
        }
    }
    out + rest
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn option_names_become_flags_and_the_rest_stays() {
        assert_eq!(
            flags_in("`engine` grid: `grid_top_density`=0: grid densities must be in (0, 10^4]"),
            "--engine grid: --grid-top-density 0: grid densities must be in (0, 10^4]"
        );
        assert_eq!(
            flags_in("lower `grid_leaf_density`, or raise `max_memory`"),
            "lower --grid-leaf-density, or raise --max-memory"
        );
        assert_eq!(
            flags_in("build with `cargo build --release --features embree`"),
            "build with `cargo build --release --features embree`"
        );
        assert_eq!(
            flags_in("`not_an_option`=3 and a `"),
            "`not_an_option`=3 and a `"
        );
    }
}
