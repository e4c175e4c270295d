//! Segment tables: whitespace-separated text with a header naming the columns, one fault
//! segment a line.

use std::path::Path;

use super::segment::{DepthRef, FaultSegment};
use crate::error::{Error, Result};

/// Columns a segment table must name in its header.
const REQUIRED_COLUMNS: [&str; 9] = [
    "x_m",
    "y_m",
    "depth_m",
    "strike_deg",
    "dip_deg",
    "rake_deg",
    "length_m",
    "width_m",
    "slip_m",
];

/// Columns a segment table may add; missing ones take opening 0 and a centroid depth.
const OPTIONAL_COLUMNS: [&str; 2] = ["opening_m", "depth_ref"];

/// Parses a whitespace-separated table of fault segments. The first line that is not blank
/// or a comment names the columns, in any order: `x_m y_m depth_m strike_deg dip_deg rake_deg
/// length_m width_m slip_m`, optionally `opening_m` and `depth_ref` (top, centroid or bottom;
/// centroid when absent). `#` starts a comment. Every segment is validated; errors name `path`,
/// the line and the column.
pub fn parse_segment_table(text: &str, path: &Path) -> Result<Vec<FaultSegment>> {
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(index, line)| (index + 1, line.split('#').next().unwrap_or("").trim()))
        .filter(|(_, line)| !line.is_empty());

    let (header_line, header) = lines.next().ok_or_else(|| {
        Error::format(
            path,
            format!(
                "no header line; expected the column names {} [opening_m] [depth_ref]",
                REQUIRED_COLUMNS.join(" ")
            ),
        )
    })?;
    let columns: Vec<&str> = header.split_whitespace().collect();
    check_segment_columns(&columns, header_line, path)?;
    let mut segments = Vec::new();
    for (line_number, line) in lines {
        segments.push(parse_segment_row(line, line_number, &columns, path)?);
    }
    if segments.is_empty() {
        return Err(Error::format(
            path,
            "the table has a header but no fault segments",
        ));
    }
    Ok(segments)
}

/// Refuses a segment-table header with an unknown or repeated column or without a required one.
fn check_segment_columns(columns: &[&str], header_line: usize, path: &Path) -> Result<()> {
    for (index, name) in columns.iter().enumerate() {
        if !REQUIRED_COLUMNS.contains(name) && !OPTIONAL_COLUMNS.contains(name) {
            return Err(Error::format(
                path,
                format!(
                    "line {header_line}, column {}: unknown column '{name}'; known columns are {} {}",
                    index + 1,
                    REQUIRED_COLUMNS.join(" "),
                    OPTIONAL_COLUMNS.join(" ")
                ),
            ));
        }
        if columns[..index].contains(name) {
            return Err(Error::format(
                path,
                format!(
                    "line {header_line}, column {}: column '{name}' appears twice",
                    index + 1
                ),
            ));
        }
    }
    if let Some(missing) = REQUIRED_COLUMNS.iter().find(|name| !columns.contains(name)) {
        return Err(Error::format(
            path,
            format!("line {header_line}: the header lacks the required column '{missing}'"),
        ));
    }
    Ok(())
}

/// One validated fault segment from a table row under the header `columns`.
fn parse_segment_row(
    line: &str,
    line_number: usize,
    columns: &[&str],
    path: &Path,
) -> Result<FaultSegment> {
    let values: Vec<&str> = line.split_whitespace().collect();
    if values.len() != columns.len() {
        return Err(Error::format(
            path,
            format!(
                "line {line_number}: expected {} values (one per header column), found {}",
                columns.len(),
                values.len()
            ),
        ));
    }
    let mut segment = FaultSegment {
        opening_m: 0.0,
        depth_ref: DepthRef::Centroid,
        ..FaultSegment::paper_case_ii()
    };
    for (index, (&name, &token)) in columns.iter().zip(&values).enumerate() {
        let located = |msg: String| {
            Error::format(
                path,
                format!("line {line_number}, column {} ({name}): {msg}", index + 1),
            )
        };
        if name == "depth_ref" {
            segment.depth_ref = DepthRef::parse(token).map_err(|error| match error {
                Error::Invalid { msg, .. } => located(msg),
                other => other,
            })?;
            continue;
        }
        let value: f64 = token
            .parse()
            .map_err(|_| located(format!("expected a number, found '{token}'")))?;
        let slot = match name {
            "x_m" => &mut segment.x_m,
            "y_m" => &mut segment.y_m,
            "depth_m" => &mut segment.depth_m,
            "strike_deg" => &mut segment.strike_deg,
            "dip_deg" => &mut segment.dip_deg,
            "rake_deg" => &mut segment.rake_deg,
            "length_m" => &mut segment.length_m,
            "width_m" => &mut segment.width_m,
            "slip_m" => &mut segment.slip_m,
            _ => &mut segment.opening_m,
        };
        *slot = value;
    }
    segment.validate().map_err(|error| match error {
        Error::Invalid { field, msg } => {
            let place = match columns.iter().position(|name| *name == field) {
                Some(index) => format!("line {line_number}, column {} ({field})", index + 1),
                None => format!("line {line_number} ({field})"),
            };
            Error::format(path, format!("{place}: {msg}"))
        }
        other => other,
    })?;
    Ok(segment)
}
