//! Command-line lists shared by the plugin's whole-app benches.

/// The comma-separated values after `flag` (`--entities 1000,100000`), or `default` when the
/// flag is absent. Panics with the flag's name on a value that does not parse: a bench run
/// with a mistyped argument should stop, not measure something else.
pub fn list<T: std::str::FromStr + Clone>(args: &[String], flag: &str, default: &[T]) -> Vec<T> {
    match args.iter().position(|a| a == flag) {
        Some(i) => args[i + 1]
            .split(',')
            .map(|s| {
                s.parse()
                    .unwrap_or_else(|_| panic!("bad value for {flag}: {s}"))
            })
            .collect(),
        None => default.to_vec(),
    }
}
