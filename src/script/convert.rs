//! Conversions between Rhai values and hdrvis types: numbers that may be written as integers or
//! floats, vectors as arrays; option maps are read through their tables (`options`).

use crate::error::Error;
use rhai::{Dynamic, EvalAltResult, Position};

pub(crate) type RResult<T> = Result<T, Box<EvalAltResult>>;

/// Library errors become Rhai runtime errors; the caller's position is filled in by Rhai.
pub(crate) fn to_rhai(e: Error) -> Box<EvalAltResult> {
    Box::new(EvalAltResult::ErrorRuntime(
        e.to_string().into(),
        Position::NONE,
    ))
}

pub(crate) fn err<T>(field: &str, msg: impl Into<String>) -> RResult<T> {
    Err(to_rhai(Error::invalid(field, msg)))
}

pub(crate) fn num(v: &Dynamic, field: &str) -> RResult<f64> {
    if let Ok(f) = v.as_float() {
        Ok(f)
    } else if let Ok(i) = v.as_int() {
        Ok(i as f64)
    } else {
        err(field, format!("expected a number, got {}", v.type_name()))
    }
}

pub(crate) fn int(v: &Dynamic, field: &str) -> RResult<i64> {
    v.as_int()
        .or_else(|_| err(field, format!("expected an integer, got {}", v.type_name())))
}

pub(crate) fn boolean(v: &Dynamic, field: &str) -> RResult<bool> {
    v.as_bool().or_else(|_| {
        err(
            field,
            format!("expected true or false, got {}", v.type_name()),
        )
    })
}

pub(crate) fn string(v: &Dynamic, field: &str) -> RResult<String> {
    v.clone()
        .into_string()
        .or_else(|t| err(field, format!("expected a string, got {t}")))
}

pub(crate) fn vec3(v: &Dynamic, field: &str) -> RResult<[f64; 3]> {
    let arr = v
        .clone()
        .into_array()
        .or_else(|t| err(field, format!("expected an array of 3 numbers, got {t}")))?;
    if arr.len() != 3 {
        return err(field, format!("expected 3 numbers, got {}", arr.len()));
    }
    Ok([
        num(&arr[0], field)?,
        num(&arr[1], field)?,
        num(&arr[2], field)?,
    ])
}

/// A pair of numbers `[a, b]` (a range, a latitude and longitude).
pub(crate) fn pair(v: &Dynamic, field: &str) -> RResult<[f64; 2]> {
    let a = v
        .clone()
        .into_array()
        .or_else(|t| err(field, format!("expected [a, b], got {t}")))?;
    if a.len() != 2 {
        return err(field, format!("expected 2 numbers, got {}", a.len()));
    }
    Ok([num(&a[0], field)?, num(&a[1], field)?])
}

/// An array of integers (positions along an axis).
pub(crate) fn ints(v: &Dynamic, field: &str) -> RResult<Vec<i64>> {
    let arr = v
        .clone()
        .into_array()
        .or_else(|t| err(field, format!("expected an array of integers, got {t}")))?;
    arr.iter().map(|d| int(d, field)).collect()
}

/// Control points [[t, value], ...].
pub(crate) fn points(v: &Dynamic, field: &str) -> RResult<Vec<[f64; 2]>> {
    let arr = v.clone().into_array().or_else(|t| {
        err(
            field,
            format!("expected an array of [t, value] pairs, got {t}"),
        )
    })?;
    arr.iter()
        .map(|p| {
            let pair = p
                .clone()
                .into_array()
                .or_else(|t| err(field, format!("expected [t, value], got {t}")))?;
            if pair.len() != 2 {
                return err(field, "expected [t, value] pairs");
            }
            Ok([num(&pair[0], field)?, num(&pair[1], field)?])
        })
        .collect()
}

/// The `variable` of a loader's options (`given`) merged with the one a `FILE:VARIABLE` path
/// named; naming two different ones is an error.
pub(crate) fn variable_option(
    given: Option<String>,
    from_path: Option<String>,
    what: &str,
) -> RResult<Option<String>> {
    match (given, from_path) {
        (Some(a), Some(b)) if a != b => err(
            what,
            format!("the path names variable {b:?} and the options variable {a:?}; give one"),
        ),
        (a, b) => Ok(a.or(b)),
    }
}

/// A number or an array of numbers, as a list.
pub(crate) fn numbers(v: &Dynamic, field: &str) -> RResult<Vec<f64>> {
    match v.clone().into_array() {
        Ok(a) => a.iter().map(|x| num(x, field)).collect(),
        Err(_) => Ok(vec![num(v, field)?]),
    }
}
