//! Script options described once. Every function that takes an options map has one
//! [`OptionTable`]: each option's name, type, allowed range or values, default and one-line doc.
//! The unknown-key check, the typed reading (ranges checked on the value as the script wrote it,
//! before any conversion), the planning run (which calls the same functions) and the option
//! lists of the API reference (`hdrvis api`, docs/api.md) all come from that table.

use super::convert::{err, to_rhai, RResult};
use rhai::{Dynamic, Map};

/// What an option's value must be. (The examples are read by the tests that walk every table.)
#[derive(Clone, Copy, Debug)]
#[cfg_attr(not(test), allow(dead_code))]
pub(crate) enum Kind {
    /// An integer in `lo..=hi`.
    Int(i64, i64),
    /// A finite number in `lo..=hi` (integers accepted).
    Num(f64, f64),
    /// A finite number greater than `lo` and at most `hi`.
    NumAbove(f64, f64),
    /// Any finite number.
    Finite,
    Bool,
    /// One of these strings.
    Choice(&'static [&'static str]),
    /// Any string, which the function checks (a colour map, a property name, ...); with an
    /// example value in Rhai syntax for the reference's tests.
    Text(&'static str),
    /// A structured value described in words and read by the function itself, with an example
    /// in Rhai syntax.
    Value(&'static str, &'static str),
}

/// One option of a function.
#[derive(Debug)]
pub(crate) struct OptionSpec {
    pub name: &'static str,
    pub kind: Kind,
    /// The default as shown to users ("512", "none", "the data's range").
    pub default: &'static str,
    pub doc: &'static str,
}

/// Shorthand for table entries.
pub(crate) const fn opt(
    name: &'static str,
    kind: Kind,
    default: &'static str,
    doc: &'static str,
) -> OptionSpec {
    OptionSpec {
        name,
        kind,
        default,
        doc,
    }
}

/// The options of one function (or of one nested map such as `shading`).
#[derive(Debug)]
#[cfg_attr(not(test), allow(dead_code))]
pub(crate) struct OptionTable {
    /// How errors and the reference name the map: "render_volume", "tf_lut lens".
    pub function: &'static str,
    pub options: &'static [OptionSpec],
    /// A call of the function in Rhai with `OPTS` where the map goes, and the map of the options
    /// the call needs (`#{}` for none), for the tests that walk every table; nested tables
    /// (`shading`) put their map inside the call.
    pub call: &'static str,
    pub base: &'static str,
}

impl Kind {
    /// The type and range as the reference shows them.
    pub(crate) fn describe(&self) -> String {
        match self {
            Kind::Int(lo, i64::MAX) => format!("integer ≥ {lo}"),
            Kind::Int(lo, hi) => format!("integer {lo}..={hi}"),
            Kind::Num(lo, hi) if hi.is_infinite() => format!("number ≥ {}", show(*lo)),
            Kind::Num(lo, hi) => format!("number {}..={}", show(*lo), show(*hi)),
            Kind::NumAbove(lo, hi) if hi.is_infinite() => format!("number > {}", show(*lo)),
            Kind::NumAbove(lo, hi) => format!("number > {}, ≤ {}", show(*lo), show(*hi)),
            Kind::Finite => "number".into(),
            Kind::Bool => "true or false".into(),
            Kind::Choice(names) => names
                .iter()
                .map(|n| format!("\"{n}\""))
                .collect::<Vec<_>>()
                .join(" | "),
            Kind::Text(_) => "string".into(),
            Kind::Value(what, _) => (*what).into(),
        }
    }

    /// A value the option accepts, in Rhai syntax (for the tests that walk every table): the
    /// lower bound of a range, the last choice, the example given; for any finite number (whose
    /// range a later check holds) the default.
    #[cfg(test)]
    pub(crate) fn example(&self, default: &str) -> String {
        match self {
            Kind::Finite => match default.parse::<f64>() {
                Ok(x) => format!("{x:?}"),
                Err(_) => "1.0".into(),
            },
            Kind::Int(lo, _) => lo.to_string(),
            Kind::Num(lo, _) => format!("{lo:?}"),
            Kind::NumAbove(lo, hi) => format!("{:?}", (lo + 1.0).min(*hi)),
            Kind::Bool => "true".into(),
            Kind::Choice(names) => format!("{:?}", names[names.len() - 1]),
            Kind::Text(example) | Kind::Value(_, example) => (*example).into(),
        }
    }
}

/// A bound as users write it: 1e12 rather than 1000000000000.
fn show(x: f64) -> String {
    if x.abs() >= 1e6 && x.fract() == 0.0 {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

/// A value as the script wrote it, for error messages.
fn as_written(v: &Dynamic) -> String {
    if let Ok(s) = v.clone().into_string() {
        format!("{s:?}")
    } else {
        v.to_string()
    }
}

impl OptionTable {
    /// An option that is a switch or a map of this table's options (`shading`, `cut_faces`,
    /// `coastlines`): `false` is `None`, `true` builds from an empty map (every default), a map
    /// is read against the table; anything else is refused naming `field` and the options.
    pub(crate) fn switch_or_map<T>(
        &'static self,
        v: &Dynamic,
        field: &str,
        build: impl FnOnce(Given<'_>) -> RResult<T>,
    ) -> RResult<Option<T>> {
        let empty = Map::new();
        let m = if v.is_bool() {
            if !super::convert::boolean(v, field)? {
                return Ok(None);
            }
            empty
        } else {
            v.clone().try_cast::<Map>().ok_or_else(|| {
                to_rhai(crate::Error::invalid(
                    field,
                    format!(
                        "expected true, false or a map #{{ {} }}",
                        self.names().join(", ")
                    ),
                ))
            })?
        };
        build(self.read(&m)?).map(Some)
    }

    /// Checks the map's keys against the table: an unknown key is refused naming the known ones.
    pub(crate) fn read<'m>(&'static self, map: &'m Map) -> RResult<Given<'m>> {
        let mut unknown: Vec<&str> = map
            .keys()
            .map(|k| k.as_str())
            .filter(|k| self.spec(k).is_none())
            .collect();
        if !unknown.is_empty() {
            unknown.sort();
            return err(
                self.function,
                format!(
                    "unknown option{} {}; known options: {}",
                    if unknown.len() > 1 { "s" } else { "" },
                    unknown.join(", "),
                    self.names().join(", ")
                ),
            );
        }
        Ok(Given { table: self, map })
    }

    pub(crate) fn names(&self) -> Vec<&'static str> {
        self.options.iter().map(|o| o.name).collect()
    }

    fn spec(&self, name: &str) -> Option<&'static OptionSpec> {
        // The table is 'static; find on it keeps the lifetime.
        let options: &'static [OptionSpec] = self.options;
        options.iter().find(|o| o.name == name)
    }

    /// The table as reference lines: "`name` (type; default d): doc".
    pub(crate) fn reference_lines(&self) -> Vec<String> {
        self.options
            .iter()
            .map(|o| {
                let default = match o.default {
                    "required" => "required".to_string(),
                    d => format!("default {d}"),
                };
                format!("`{}` ({}; {default}): {}", o.name, o.kind.describe(), o.doc)
            })
            .collect()
    }
}

/// An options map whose keys were checked against its table; each getter reads one option,
/// checking its type and range against the table.
pub(crate) struct Given<'m> {
    table: &'static OptionTable,
    map: &'m Map,
}

impl<'m> Given<'m> {
    /// The value of `name` and its spec; a name missing from the table is a programming error
    /// reported as a script error, never a panic.
    fn get(&self, name: &str) -> RResult<(Option<&'m Dynamic>, &'static OptionSpec)> {
        match self.table.spec(name) {
            Some(spec) => Ok((self.map.get(name), spec)),
            None => err(
                self.table.function,
                format!("option {name} is not described in the option table"),
            ),
        }
    }

    fn out_of_range<T>(&self, name: &str, v: &Dynamic, spec: &OptionSpec) -> RResult<T> {
        err(
            name,
            format!("{}; expected {}", as_written(v), spec.kind.describe()),
        )
    }

    /// Whether the script gave `name`.
    pub(crate) fn has(&self, name: &str) -> bool {
        self.map.contains_key(name)
    }

    /// The raw value of a [`Kind::Value`] option, for the function to read.
    pub(crate) fn value(&self, name: &str) -> RResult<Option<&'m Dynamic>> {
        Ok(self.get(name)?.0)
    }

    /// An integer option, range-checked as written.
    pub(crate) fn int(&self, name: &str) -> RResult<Option<i64>> {
        let (Some(v), spec) = self.get(name)? else {
            return Ok(None);
        };
        let Ok(i) = v.as_int() else {
            return err(
                name,
                format!(
                    "expected an integer, got {} {}",
                    v.type_name(),
                    as_written(v)
                ),
            );
        };
        match spec.kind {
            Kind::Int(lo, hi) if (lo..=hi).contains(&i) => Ok(Some(i)),
            Kind::Int(..) => self.out_of_range(name, v, spec),
            _ => self.wrong_getter(name),
        }
    }

    /// An integer option as a size or count (the table's range is non-negative).
    pub(crate) fn count(&self, name: &str) -> RResult<Option<usize>> {
        Ok(self.int(name)?.map(|i| i.max(0) as usize))
    }

    /// A number option, finite and range-checked as written.
    pub(crate) fn num(&self, name: &str) -> RResult<Option<f64>> {
        let (Some(v), spec) = self.get(name)? else {
            return Ok(None);
        };
        let x = if let Ok(f) = v.as_float() {
            f
        } else if let Ok(i) = v.as_int() {
            i as f64
        } else {
            return err(
                name,
                format!("expected a number, got {} {}", v.type_name(), as_written(v)),
            );
        };
        let ok = match spec.kind {
            Kind::Num(lo, hi) => x.is_finite() && lo <= x && x <= hi,
            Kind::Finite => x.is_finite(),
            Kind::NumAbove(lo, hi) => x.is_finite() && lo < x && x <= hi,
            _ => return self.wrong_getter(name),
        };
        if ok {
            Ok(Some(x))
        } else {
            self.out_of_range(name, v, spec)
        }
    }

    pub(crate) fn bool(&self, name: &str) -> RResult<Option<bool>> {
        let (Some(v), spec) = self.get(name)? else {
            return Ok(None);
        };
        if !matches!(spec.kind, Kind::Bool) {
            return self.wrong_getter(name);
        }
        v.as_bool().map(Some).or_else(|_| {
            err(
                name,
                format!(
                    "expected true or false, got {} {}",
                    v.type_name(),
                    as_written(v)
                ),
            )
        })
    }

    /// A string option; for a [`Kind::Choice`] one of its names.
    pub(crate) fn string(&self, name: &str) -> RResult<Option<String>> {
        let (Some(v), spec) = self.get(name)? else {
            return Ok(None);
        };
        let Ok(s) = v.clone().into_string() else {
            return err(
                name,
                format!("expected a string, got {} {}", v.type_name(), as_written(v)),
            );
        };
        match spec.kind {
            Kind::Text(_) => Ok(Some(s)),
            Kind::Choice(names) if names.contains(&s.as_str()) => Ok(Some(s)),
            Kind::Choice(_) => self.out_of_range(name, v, spec),
            _ => self.wrong_getter(name),
        }
    }

    fn wrong_getter<T>(&self, name: &str) -> RResult<T> {
        Err(to_rhai(crate::Error::invalid(
            self.table.function,
            format!("option {name} is read as another type than its table gives"),
        )))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    static TABLE: OptionTable = OptionTable {
        function: "f",
        options: &[
            opt("n", Kind::Int(2, 2048), "33", "cells"),
            opt("step", Kind::NumAbove(0.0, 64.0), "1", "step"),
            opt("mode", Kind::Choice(&["a", "b"]), "\"a\"", "mode"),
            opt("flag", Kind::Bool, "false", "flag"),
        ],
        call: "f(OPTS)",
        base: "#{}",
    };

    fn map(pairs: &[(&str, Dynamic)]) -> Map {
        pairs
            .iter()
            .map(|(k, v)| ((*k).into(), v.clone()))
            .collect()
    }

    #[test]
    fn values_are_checked_as_written() {
        let m = map(&[("n", Dynamic::from(100_000_i64))]);
        let e = TABLE.read(&m).unwrap().int("n").unwrap_err().to_string();
        assert!(e.contains("n: 100000; expected integer 2..=2048"), "{e}");
        let m = map(&[("n", Dynamic::from(-5_i64))]);
        let e = TABLE.read(&m).unwrap().int("n").unwrap_err().to_string();
        assert!(e.contains("-5;"), "{e}");
        let m = map(&[("n", Dynamic::from(1_i64 << 62))]);
        let e = TABLE.read(&m).unwrap().int("n").unwrap_err().to_string();
        assert!(e.contains(&format!("{};", 1_i64 << 62)), "{e}");
        let m = map(&[("step", Dynamic::from(0.0_f64))]);
        let e = TABLE.read(&m).unwrap().num("step").unwrap_err().to_string();
        assert!(e.contains("step: 0.0; expected number > 0"), "{e}");
        let m = map(&[("step", Dynamic::from(f64::NAN))]);
        assert!(TABLE.read(&m).unwrap().num("step").is_err());
        let m = map(&[("step", Dynamic::from(2_i64))]);
        assert_eq!(TABLE.read(&m).unwrap().num("step").unwrap(), Some(2.0));
        let m = map(&[("mode", Dynamic::from("c"))]);
        let e = TABLE
            .read(&m)
            .unwrap()
            .string("mode")
            .unwrap_err()
            .to_string();
        assert!(e.contains("\"c\"; expected \"a\" | \"b\""), "{e}");
        let m = map(&[("flag", Dynamic::from(1_i64))]);
        let e = TABLE
            .read(&m)
            .unwrap()
            .bool("flag")
            .unwrap_err()
            .to_string();
        assert!(e.contains("expected true or false"), "{e}");
    }

    #[test]
    fn unknown_keys_and_undescribed_names_are_errors_not_panics() {
        let m = map(&[
            ("colour", Dynamic::from(1_i64)),
            ("n", Dynamic::from(3_i64)),
        ]);
        let e = TABLE.read(&m).err().unwrap().to_string();
        assert!(
            e.contains("unknown option colour; known options: n, step, mode, flag"),
            "{e}"
        );
        let m = Map::new();
        let given = TABLE.read(&m).unwrap();
        assert!(given.int("nope").is_err());
        assert!(given.num("n").is_ok(), "absent: no type check needed");
        let m = map(&[("n", Dynamic::from(3_i64))]);
        assert!(TABLE.read(&m).unwrap().num("n").is_err());
    }
}
