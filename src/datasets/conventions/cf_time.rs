//! CF time (CF conventions 1.11, section 4.4): a time coordinate's values are `<unit> since
//! <date>` in a calendar, and this module turns them into dates and dates back into values. The
//! calendars are CF's: standard/gregorian (Julian before 1582-10-15, Gregorian from then on, the
//! ten days between do not exist), proleptic_gregorian, noleap/365_day, all_leap/366_day, 360_day
//! and julian; the units seconds, minutes, hours and days, and months and years as udunits
//! defines them (a year of 365.242198781 days, a month a twelfth of it; CF 4.4 warns that they
//! are not calendar months) except where the calendar makes them exact: cftime's months of 30
//! days in the 360_day calendar (with years of 360 days) and its common years of 365 days in
//! noleap. Each calendar counts days from its own day 0, so a date is a day
//! number and the seconds into that day; dates are written in ISO 8601 to the second, with
//! astronomical year numbers (the year before 1 is 0).

use crate::error::{Error, Result};

/// A CF calendar.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Calendar {
    Standard,
    ProlepticGregorian,
    NoLeap,
    AllLeap,
    Day360,
    Julian,
}

/// The calendar names CF defines, for error messages.
const CALENDAR_NAMES: &str =
    "standard, gregorian, proleptic_gregorian, noleap, 365_day, all_leap, 366_day, 360_day, julian";

/// Seconds in a day.
const DAY: f64 = 86_400.0;

/// udunits' year (the tropical year, 365.242198781 days) in seconds, which its `month` divides
/// by twelve.
const UDUNITS_YEAR: f64 = 365.242_198_781 * DAY;

/// The Julian day number of 1582-10-15, the first day of the Gregorian calendar.
const GREGORIAN_START: i64 = 2_299_161;

impl Calendar {
    /// The calendar CF names `name` (any case); `None` for a name CF does not define.
    pub fn parse(name: &str) -> Option<Calendar> {
        Some(match name.trim().to_ascii_lowercase().as_str() {
            "standard" | "gregorian" => Calendar::Standard,
            "proleptic_gregorian" => Calendar::ProlepticGregorian,
            "noleap" | "365_day" => Calendar::NoLeap,
            "all_leap" | "366_day" => Calendar::AllLeap,
            "360_day" => Calendar::Day360,
            "julian" => Calendar::Julian,
            _ => return None,
        })
    }

    pub fn name(self) -> &'static str {
        match self {
            Calendar::Standard => "standard",
            Calendar::ProlepticGregorian => "proleptic_gregorian",
            Calendar::NoLeap => "noleap",
            Calendar::AllLeap => "all_leap",
            Calendar::Day360 => "360_day",
            Calendar::Julian => "julian",
        }
    }

    fn month_length(self, year: i64, month: i64) -> i64 {
        const DAYS: [i64; 12] = [31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31];
        let leap = match self {
            Calendar::Day360 => return 30,
            Calendar::NoLeap => false,
            Calendar::AllLeap => true,
            Calendar::Julian => year.rem_euclid(4) == 0,
            Calendar::ProlepticGregorian => gregorian_leap(year),
            Calendar::Standard if year < 1582 => year.rem_euclid(4) == 0,
            Calendar::Standard => gregorian_leap(year),
        };
        DAYS[(month - 1) as usize] + i64::from(leap && month == 2)
    }

    /// The day number of a date, or an error naming it when the calendar has no such day.
    fn day_number(self, (year, month, day): (i64, i64, i64)) -> Result<i64> {
        let bad = || {
            Error::invalid(
                "date",
                format!(
                    "{} is not a day of the {} calendar",
                    format_ymd(year, month, day),
                    self.name()
                ),
            )
        };
        if !(1..=12).contains(&month) || day < 1 || day > self.month_length(year, month) {
            return Err(bad());
        }
        let before_month = |len: fn(i64) -> i64| (1..month).map(len).sum::<i64>();
        Ok(match self {
            Calendar::Day360 => year * 360 + (month - 1) * 30 + day - 1,
            Calendar::NoLeap => {
                year * 365 + before_month(|m| Calendar::NoLeap.month_length(1, m)) + day - 1
            }
            Calendar::AllLeap => {
                year * 366 + before_month(|m| Calendar::AllLeap.month_length(1, m)) + day - 1
            }
            Calendar::Julian => julian_day(year, month, day, false),
            Calendar::ProlepticGregorian => julian_day(year, month, day, true),
            Calendar::Standard => {
                let gregorian = julian_day(year, month, day, true);
                if gregorian >= GREGORIAN_START {
                    gregorian
                } else if (year, month, day) < (1582, 10, 5) {
                    julian_day(year, month, day, false)
                } else {
                    return Err(bad());
                }
            }
        })
    }

    /// The date of a day number.
    fn date(self, n: i64) -> (i64, i64, i64) {
        let from_year_day = |year: i64, mut day: i64| {
            let mut month = 1;
            while day >= self.month_length(year, month) {
                day -= self.month_length(year, month);
                month += 1;
            }
            (year, month, day + 1)
        };
        match self {
            Calendar::Day360 => {
                let day = n.rem_euclid(360);
                (n.div_euclid(360), day / 30 + 1, day % 30 + 1)
            }
            Calendar::NoLeap => from_year_day(n.div_euclid(365), n.rem_euclid(365)),
            Calendar::AllLeap => from_year_day(n.div_euclid(366), n.rem_euclid(366)),
            Calendar::Julian => civil_date(n, false),
            Calendar::ProlepticGregorian => civil_date(n, true),
            Calendar::Standard => civil_date(n, n >= GREGORIAN_START),
        }
    }
}

fn gregorian_leap(year: i64) -> bool {
    year.rem_euclid(4) == 0 && (year.rem_euclid(100) != 0 || year.rem_euclid(400) == 0)
}

/// The Julian day number of a date of the Gregorian or the Julian calendar (Richards, "Mapping
/// time", 2013, with floor division so that any year works).
fn julian_day(year: i64, month: i64, day: i64, gregorian: bool) -> i64 {
    let a = (14 - month).div_euclid(12);
    let y = year + 4800 - a;
    let m = month + 12 * a - 3;
    let base = day + (153 * m + 2).div_euclid(5) + 365 * y + y.div_euclid(4);
    if gregorian {
        base - y.div_euclid(100) + y.div_euclid(400) - 32_045
    } else {
        base - 32_083
    }
}

/// The inverse of [`julian_day`].
fn civil_date(n: i64, gregorian: bool) -> (i64, i64, i64) {
    let (b, c) = if gregorian {
        let a = n + 32_044;
        let b = (4 * a + 3).div_euclid(146_097);
        (b, a - (146_097 * b).div_euclid(4))
    } else {
        (0, n + 32_082)
    };
    let d = (4 * c + 3).div_euclid(1461);
    let e = c - (1461 * d).div_euclid(4);
    let m = (5 * e + 2).div_euclid(153);
    let day = e - (153 * m + 2).div_euclid(5) + 1;
    let month = m + 3 - 12 * m.div_euclid(10);
    let year = 100 * b + d - 4800 + m.div_euclid(10);
    (year, month, day)
}

fn format_ymd(year: i64, month: i64, day: i64) -> String {
    if (0..=9999).contains(&year) {
        format!("{year:04}-{month:02}-{day:02}")
    } else {
        format!("{year:+05}-{month:02}-{day:02}")
    }
}

/// A time axis: `<unit> since <epoch>` in a calendar.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct TimeUnits {
    pub calendar: Calendar,
    /// Seconds per unit.
    unit: f64,
    /// How a unit that is not a fixed length of time was read ("months of 30.436851 days
    /// (udunits)"), for reports; `None` for seconds to days.
    pub unit_note: Option<String>,
    /// The epoch in seconds from the calendar's day 0.
    epoch: f64,
    /// `day as %Y%m%d.%f` (CDO, ICON): values are dates, 20240115.5 for noon of 15 January 2024.
    absolute: bool,
}

impl TimeUnits {
    /// Parses a CF `units` string and `calendar` attribute (absent: standard). Errors name what
    /// was expected.
    pub fn parse(units: &str, calendar: Option<&str>) -> Result<TimeUnits> {
        let calendar = match calendar {
            None => Calendar::Standard,
            Some(name) => Calendar::parse(name).ok_or_else(|| {
                Error::invalid(
                    "calendar",
                    format!("unknown calendar '{name}'; expected one of {CALENDAR_NAMES}"),
                )
            })?,
        };
        let lower = units.trim().to_ascii_lowercase();
        if ABSOLUTE_UNITS.contains(&lower.as_str()) {
            return Ok(TimeUnits {
                calendar,
                unit: DAY,
                unit_note: Some(
                    "dates written as YYYYMMDD.fraction of a day (CDO's absolute time)".into(),
                ),
                epoch: 0.0,
                absolute: true,
            });
        }
        let Some((unit, epoch)) = lower.split_once(" since ") else {
            return Err(Error::invalid(
                "units",
                format!("'{units}' is not '<unit> since <date>' or 'day as %Y%m%d.%f'"),
            ));
        };
        let (unit, unit_note) = parse_unit(units, unit.trim(), calendar)?;
        let epoch = parse_instant(calendar, epoch, true)?;
        Ok(TimeUnits {
            calendar,
            unit,
            unit_note,
            epoch,
            absolute: false,
        })
    }

    /// Seconds from the calendar's day 0 of an absolute value YYYYMMDD.fraction; `None` when its
    /// digits are no date of the calendar.
    fn absolute_seconds(&self, value: f64) -> Option<f64> {
        let day = value.floor();
        let ymd = day as i64;
        let n = self
            .calendar
            .day_number((ymd / 10000, ymd / 100 % 100, ymd % 100))
            .ok()?;
        Some(n as f64 * DAY + (value - day) * DAY)
    }

    /// The date of coordinate value `value`, in ISO 8601 to the nearest second.
    pub fn date(&self, value: f64) -> String {
        let seconds = if self.absolute {
            match self.absolute_seconds(value) {
                Some(s) => s.round(),
                None => return format!("{value} (not a YYYYMMDD date)"),
            }
        } else {
            (self.epoch + value * self.unit).round()
        };
        let day = (seconds / DAY).floor();
        let in_day = (seconds - day * DAY) as i64;
        let (y, m, d) = self.calendar.date(day as i64);
        format!(
            "{}T{:02}:{:02}:{:02}",
            format_ymd(y, m, d),
            in_day / 3600,
            in_day / 60 % 60,
            in_day % 60
        )
    }

    /// The coordinate value of an ISO 8601 date (`2011-03-11`, `2011-03-11T06:00`,
    /// `2011-03-11 06:00:30`, a trailing `Z`) in this calendar.
    pub fn value(&self, date: &str) -> Result<f64> {
        let seconds = parse_instant(self.calendar, date, false)?;
        if self.absolute {
            let day = (seconds / DAY).floor();
            let (y, m, d) = self.calendar.date(day as i64);
            return Ok((y * 10000 + m * 100 + d) as f64 + (seconds - day * DAY) / DAY);
        }
        Ok((seconds - self.epoch) / self.unit)
    }
}

/// The units of absolute time axes, as CDO and ICON write them (lower case).
const ABSOLUTE_UNITS: [&str; 3] = ["day as %y%m%d.%f", "days as %y%m%d.%f", "day as %y%m%d"];

/// Whether `units` are those of a time axis: `<unit> since <date>`, or absolute days.
pub(crate) fn is_time_units(units: &str) -> bool {
    let lower = units.trim().to_ascii_lowercase();
    lower.contains(" since ") || ABSOLUTE_UNITS.contains(&lower.as_str())
}

/// Seconds per time unit `unit` (of the units string `units`) in `calendar`, and how a unit of
/// no fixed length was read.
fn parse_unit(units: &str, unit: &str, calendar: Calendar) -> Result<(f64, Option<String>)> {
    let fixed = match unit {
        "second" | "seconds" | "sec" | "secs" | "s" => Some(1.0),
        "minute" | "minutes" | "min" | "mins" => Some(60.0),
        "hour" | "hours" | "hr" | "hrs" | "h" => Some(3600.0),
        "day" | "days" | "d" => Some(DAY),
        _ => None,
    };
    if let Some(seconds) = fixed {
        return Ok((seconds, None));
    }
    let (seconds, rule) = match (unit, calendar) {
        ("month" | "months", Calendar::Day360) => (30.0 * DAY, "cftime's 360_day rule"),
        ("year" | "years" | "yr", Calendar::Day360) => (360.0 * DAY, "the 360_day calendar"),
        ("common_year" | "common_years", Calendar::NoLeap) => (365.0 * DAY, "cftime's noleap rule"),
        ("month" | "months", _) => (UDUNITS_YEAR / 12.0, "udunits"),
        ("year" | "years" | "yr", _) => (UDUNITS_YEAR, "udunits"),
        (other, _) => {
            return Err(Error::invalid(
                "units",
                format!(
                    "time unit '{other}' in '{units}'; expected seconds, minutes, hours, days, months or years"
                ),
            ))
        }
    };
    let name = if unit.starts_with('m') {
        "months"
    } else {
        "years"
    };
    let note = format!("{name} of {:.6} days ({rule})", seconds / DAY);
    Ok((seconds, Some(note)))
}

/// Seconds from the calendar's day 0 of a date and optional time. A units string's epoch
/// (`lenient`) may also write the date without zero padding and end in `UTC`.
fn parse_instant(calendar: Calendar, text: &str, lenient: bool) -> Result<f64> {
    let bad = || {
        Error::invalid(
            "date",
            format!("'{text}' is not an ISO 8601 date (YYYY-MM-DD, YYYY-MM-DDTHH:MM[:SS])"),
        )
    };
    let mut t = text.trim();
    for suffix in ["z", "Z", "utc", "UTC", "gmt", "GMT", "+00:00", "+0000"] {
        if lenient || suffix.eq_ignore_ascii_case("z") {
            t = t.strip_suffix(suffix).unwrap_or(t).trim_end();
        }
    }
    let (date, mut time) = match t.split_once(['T', 't', ' ']) {
        Some((d, rest)) => (d, Some(rest.trim())),
        None => (t, None),
    };
    // udunits' time zone after the time, as ARM writes "2019-01-01 00:00:00 0:00": local time
    // is UTC plus the offset.
    let mut zone_seconds = 0.0;
    if let Some((clock, zone)) = time.and_then(|c| c.split_once(char::is_whitespace)) {
        if !lenient {
            return Err(bad());
        }
        zone_seconds = parse_zone(zone.trim()).ok_or_else(bad)?;
        time = Some(clock);
    }
    let (sign, digits) = match date.strip_prefix('-') {
        Some(rest) => (-1, rest),
        None => (1, date.strip_prefix('+').unwrap_or(date)),
    };
    let parts: Vec<&str> = digits.split('-').collect();
    let number = |s: &str, width: Option<usize>| -> Result<i64> {
        let ok = !s.is_empty()
            && s.bytes().all(|b| b.is_ascii_digit())
            && (lenient || width.is_none_or(|w| s.len() == w));
        if ok {
            s.parse().map_err(|_| bad())
        } else {
            Err(bad())
        }
    };
    let [y, m, d] = parts[..] else {
        return Err(bad());
    };
    let ymd = (
        sign * number(y, None)?,
        number(m, Some(2))?,
        number(d, Some(2))?,
    );
    if !lenient && y.len() < 4 {
        return Err(bad());
    }
    let seconds = match time.filter(|s| !s.is_empty()) {
        None => 0.0,
        Some(time) => {
            let fields: Vec<&str> = time.split(':').collect();
            if !(2..=3).contains(&fields.len()) {
                return Err(bad());
            }
            let h = number(fields[0], Some(2))?;
            let min = number(fields[1], Some(2))?;
            let s: f64 = match fields.get(2) {
                None => 0.0,
                Some(s) => s
                    .parse()
                    .ok()
                    .filter(|v: &f64| (0.0..60.0).contains(v))
                    .ok_or_else(bad)?,
            };
            if h > 23 || min > 59 {
                return Err(bad());
            }
            (h * 3600 + min * 60) as f64 + s
        }
    };
    let day = calendar.day_number(ymd)?;
    Ok(day as f64 * DAY + seconds - zone_seconds)
}

/// Seconds east of UTC of a udunits time zone: `[+|-]H[H][[:]MM]` ("0:00", "-6", "+05:30").
fn parse_zone(zone: &str) -> Option<f64> {
    let (sign, rest) = match zone.as_bytes().first()? {
        b'-' => (-1.0, &zone[1..]),
        b'+' => (1.0, &zone[1..]),
        _ => (1.0, zone),
    };
    let (h, m) = match rest.split_once(':') {
        Some((h, m)) => (h, m),
        None if rest.len() > 2 => rest.split_at(rest.len() - 2),
        None => (rest, "0"),
    };
    let digits = |s: &str| !s.is_empty() && s.len() <= 2 && s.bytes().all(|b| b.is_ascii_digit());
    if !(digits(h) && digits(m)) {
        return None;
    }
    let (h, m): (f64, f64) = (h.parse().ok()?, m.parse().ok()?);
    (h <= 14.0 && m < 60.0).then_some(sign * (h * 3600.0 + m * 60.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn axis(units: &str, calendar: &str) -> TimeUnits {
        TimeUnits::parse(units, Some(calendar)).unwrap()
    }

    #[test]
    fn day_numbers_round_trip_in_every_calendar() {
        for cal in [
            Calendar::Standard,
            Calendar::ProlepticGregorian,
            Calendar::NoLeap,
            Calendar::AllLeap,
            Calendar::Day360,
            Calendar::Julian,
        ] {
            let start = cal.day_number((-500, 1, 1)).unwrap();
            let mut last = cal.date(start - 1);
            for n in start..start + 3000 * 366 {
                let date = cal.date(n);
                assert_eq!(cal.day_number(date).unwrap(), n, "{cal:?} {date:?}");
                assert!(date > last, "{cal:?}: {date:?} after {last:?}");
                last = date;
            }
        }
    }

    #[test]
    fn the_standard_calendar_skips_the_reform_days() {
        let t = axis("days since 1582-10-15", "gregorian");
        assert_eq!(t.date(-1.0), "1582-10-04T00:00:00");
        assert_eq!(t.date(0.0), "1582-10-15T00:00:00");
        // 1500 is a leap year in the Julian calendar, not in the Gregorian one.
        let t = axis("days since 1500-02-28", "standard");
        assert_eq!(t.date(1.0), "1500-02-29T00:00:00");
        let t = axis("days since 1500-02-28", "proleptic_gregorian");
        assert_eq!(t.date(1.0), "1500-03-01T00:00:00");
        // The reform's gap exists only in the standard calendar.
        // cftime.date2num gives 30174 for it.
        assert_eq!(t.value("1582-10-10").unwrap(), 30_174.0);
        let err = axis("days since 2000-01-01", "standard")
            .value("1582-10-10")
            .unwrap_err()
            .to_string();
        assert!(err.contains("not a day of the standard calendar"), "{err}");
    }

    #[test]
    fn absolute_day_units_are_dates() {
        // CDO's `-a` absolute time axis: 20240115.5 is noon on 15 January 2024.
        let units = TimeUnits::parse("day as %Y%m%d.%f", Some("proleptic_gregorian")).unwrap();
        assert_eq!(units.date(20240115.5), "2024-01-15T12:00:00");
        assert_eq!(units.date(20240229.25), "2024-02-29T06:00:00");
        assert_eq!(units.value("2024-03-01T18:00").unwrap(), 20240301.75);
        assert!(units.date(20240230.0).contains("not a YYYYMMDD date"));
        let day360 = TimeUnits::parse("day as %Y%m%d.%f", Some("360_day")).unwrap();
        assert_eq!(day360.date(20240230.0), "2024-02-30T00:00:00");
    }

    #[test]
    fn values_become_dates_and_back() {
        // Unix time: 1e9 s is 2001-09-09T01:46:40 (a known instant).
        let t = axis("seconds since 1970-01-01 00:00:00 UTC", "standard");
        assert_eq!(t.date(1e9), "2001-09-09T01:46:40");
        assert_eq!(t.value("2001-09-09T01:46:40Z").unwrap(), 1e9);
        // 360_day: months of 30 days; a negative offset runs back into 1999.
        let t = axis("days since 2000-01-01", "360_day");
        assert_eq!(t.date(-45.0), "1999-11-16T00:00:00");
        assert_eq!(t.date(59.0), "2000-02-30T00:00:00");
        assert_eq!(t.value("1999-11-16T00:00").unwrap(), -45.0);
        let t = axis("hours since 1-1-1 0:0:0", "noleap");
        assert_eq!(
            t.date(365.0 * 24.0 * 3.0 + 59.0 * 24.0),
            "0004-03-01T00:00:00"
        );
        let t = axis("days since 2000-01-01", "all_leap");
        assert_eq!(t.date(365.0), "2000-12-31T00:00:00");
        let t = axis("minutes since 1900-03-01", "julian");
        assert_eq!(t.date(-24.0 * 60.0), "1900-02-29T00:00:00");
    }

    #[test]
    fn months_and_years_follow_cftime_in_360_day_and_udunits_elsewhere() {
        // cftime.num2date([0, 1, 2, 13, 25.5], "months since 1958-1-1", "360_day").
        let t = axis("months since 1958-1-1", "360_day");
        let dates: Vec<String> = [0.0, 1.0, 2.0, 13.0, 25.5].map(|v| t.date(v)).to_vec();
        assert_eq!(
            dates,
            [
                "1958-01-01T00:00:00",
                "1958-02-01T00:00:00",
                "1958-03-01T00:00:00",
                "1959-02-01T00:00:00",
                "1960-02-16T00:00:00"
            ]
        );
        assert!(t.unit_note.as_deref().unwrap().contains("30.000000 days"));
        // udunits: a month is 365.242198781 / 12 = 30.436849898 days, so month 12 of 2001
        // (no leap day) ends 365.242 days on: 2002-01-01T05:48:46.
        let t = axis("months since 2001-01-01", "standard");
        assert_eq!(t.date(12.0), "2002-01-01T05:48:46");
        assert_eq!(t.date(1.0), "2001-01-31T10:29:04");
        assert!(t.unit_note.as_deref().unwrap().contains("udunits"));
        let t = axis("years since 2000-01-01", "proleptic_gregorian");
        assert_eq!(t.date(4.0), "2003-12-31T23:15:04");
        let t = axis("common_years since 2000-01-01", "noleap");
        assert_eq!(t.date(3.0), "2003-01-01T00:00:00");
        assert!(TimeUnits::parse("common_years since 2000-01-01", None).is_err());
    }

    #[test]
    fn udunits_time_zones_shift_the_epoch_to_utc() {
        // ARM's units; and a zone east of UTC puts the epoch earlier in UTC.
        let t = axis("seconds since 2019-01-01 00:00:00 0:00", "standard");
        assert_eq!(t.date(60.0), "2019-01-01T00:01:00");
        let t = axis("hours since 2000-01-01 06:00 +05:30", "standard");
        assert_eq!(t.date(0.0), "2000-01-01T00:30:00");
        let t = axis("hours since 2000-01-01 00:00:00 -06:00", "standard");
        assert_eq!(t.date(0.0), "2000-01-01T06:00:00");
        assert!(TimeUnits::parse("days since 2000-01-01 00:00 +25:00", None).is_err());
    }

    #[test]
    fn bad_units_calendars_and_dates_are_named() {
        let e = TimeUnits::parse("days since 2000-01-01", Some("lunar"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("unknown calendar 'lunar'"), "{e}");
        let e = TimeUnits::parse("fortnights since 2000-01-01", None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("time unit 'fortnights'"), "{e}");
        let t = axis("days since 2000-01-01", "standard");
        for bad in [
            "11/03/2011",
            "2011-3-11",
            "2011-03-11T6",
            "2011-03-11T25:00",
            "March",
        ] {
            let e = t.value(bad).unwrap_err().to_string();
            assert!(e.contains("not an ISO 8601 date"), "{bad}: {e}");
        }
    }
}
