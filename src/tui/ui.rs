//! Layout and drawing, pure functions of the [`App`] state and the encoded image: the picture on
//! the left, the parameter panel and the log-luminance histogram on the right, a status line
//! (adapter, render time, passes, protocol, notices), a script error box with line and caret
//! over the bottom of the picture, and the help overlay listing [`KEYS`]. Tested with ratatui's
//! `TestBackend`.

use crate::script::ParamKind;
use crate::tui::app::{App, Source, KEYS};
use crate::tui::protocol::Picture;
use crate::tui::scene::format_number;
use ratatui::layout::{Constraint, Direction, Layout, Rect};
use ratatui::style::{Color, Modifier, Style};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Borders, Clear, Paragraph, Wrap};
use ratatui::Frame;

/// Width of the right-hand column (parameters and histogram).
const PANEL_WIDTH: u16 = 30;
/// Height of the histogram box, borders included.
const HISTOGRAM_HEIGHT: u16 = 8;

/// Where everything goes on a screen of a given size.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Areas {
    pub image_block: Rect,
    /// Inside the image's border: the cells the picture may cover.
    pub image: Rect,
    pub params: Rect,
    pub histogram: Rect,
    pub status: Rect,
}

/// The layout of a `size` screen. Below 60 columns the panel is dropped and the picture takes
/// the width; the status line is always the last row (the picture never touches it, so a sixel
/// image cannot scroll the screen).
pub(crate) fn layout(size: Rect) -> Areas {
    let rows = Layout::default()
        .direction(Direction::Vertical)
        .constraints([Constraint::Min(3), Constraint::Length(1)])
        .split(size);
    let panel = if size.width >= 60 { PANEL_WIDTH } else { 0 };
    let cols = Layout::default()
        .direction(Direction::Horizontal)
        .constraints([Constraint::Min(10), Constraint::Length(panel)])
        .split(rows[0]);
    let right = Layout::default()
        .direction(Direction::Vertical)
        .constraints([
            Constraint::Min(3),
            Constraint::Length(HISTOGRAM_HEIGHT.min(rows[0].height / 2)),
        ])
        .split(cols[1]);
    let image_block = cols[0];
    Areas {
        image_block,
        image: Block::default().borders(Borders::ALL).inner(image_block),
        params: right[0],
        histogram: right[1],
        status: rows[1],
    }
}

/// The cells a picture may cover on a `columns` × `rows` screen (for benchmarks, which have no
/// terminal).
pub(crate) fn picture_area(columns: u16, rows: u16) -> PictureArea {
    layout(Rect::new(0, 0, columns, rows)).image
}

/// A rectangle of terminal cells.
pub(crate) type PictureArea = Rect;

/// Draws the whole screen. `image` is the picture already encoded for the terminal's protocol
/// and sized for [`Areas::image`].
pub(crate) fn draw(frame: &mut Frame, app: &App, image: Option<&Picture>) {
    let areas = layout(frame.area());
    let title = match &app.source {
        Source::Script(p) | Source::Image(p) => p
            .file_name()
            .map(|n| n.to_string_lossy().to_string())
            .unwrap_or_default(),
    };
    let image_block = Block::default().borders(Borders::ALL).title(Span::styled(
        format!(" {title} "),
        Style::default().add_modifier(Modifier::BOLD),
    ));
    frame.render_widget(image_block, areas.image_block);
    match image {
        Some(Picture::Widget(protocol)) => {
            frame.render_widget(ratatui_image::Image::new(protocol), areas.image)
        }
        // Placed by the event loop after the frame; the cells under it stay blank.
        Some(Picture::KittyDirect(_)) => {}
        None => {
            let text = if app.status.busy {
                "rendering…"
            } else if app.error.is_some() {
                "no image yet: the script failed"
            } else {
                "no image"
            };
            frame.render_widget(Paragraph::new(text), areas.image);
        }
    }
    if let Some(err) = &app.error {
        draw_error(frame, areas.image, err);
    }
    if areas.params.width > 0 {
        draw_params(frame, app, areas.params);
        draw_histogram(frame, app, areas.histogram);
    }
    draw_status(frame, app, areas.status);
    if app.show_help {
        draw_help(frame, frame.area());
    }
}

/// The script error (file:line:column, source line, caret) in a red box over the bottom of the
/// picture; the last good image stays visible above it.
fn draw_error(frame: &mut Frame, area: Rect, err: &str) {
    let lines: Vec<Line> = err.lines().map(|l| Line::from(l.to_string())).collect();
    let height = (lines.len() as u16 + 2).min(area.height);
    let rect = Rect::new(area.x, area.bottom() - height, area.width, height);
    frame.render_widget(Clear, rect);
    frame.render_widget(
        Paragraph::new(lines).block(
            Block::default()
                .borders(Borders::ALL)
                .border_style(Style::default().fg(Color::Red))
                .title(" script error (last good image kept) "),
        ),
        rect,
    );
}

fn draw_params(frame: &mut Frame, app: &App, area: Rect) {
    let key = Style::default().fg(Color::Cyan);
    let mut lines = vec![
        Line::from(vec![
            Span::styled("exposure ", key),
            Span::raw(format!("{:+.1} EV", app.view.exposure_ev)),
        ]),
        Line::from(vec![
            Span::styled("operator ", key),
            Span::raw(app.view.operator_label()),
        ]),
        Line::from(vec![
            Span::styled("channel  ", key),
            Span::raw(format!(
                "{}{}",
                app.view.channel.label(),
                if app.view.false_colour {
                    " false colour"
                } else {
                    ""
                }
            )),
        ]),
    ];
    if let Some(hdr) = &app.hdr {
        lines.push(Line::from(vec![
            Span::styled("image    ", key),
            Span::raw(format!("{}×{} {}", hdr.width, hdr.height, app.status.stage)),
        ]));
    }
    lines.extend(edit_lines(app, key));
    let params = app.panel_params();
    if !params.is_empty() {
        lines.push(Line::from(Span::styled(
            "── script parameters ──",
            Style::default().fg(Color::DarkGray),
        )));
    }
    for (i, p) in params.iter().enumerate() {
        let value = app.param_value(&p.name).unwrap_or_default();
        let value = match (p.kind, value.trim().parse::<f64>()) {
            (ParamKind::Float, Ok(v)) => format_number(v),
            _ => value,
        };
        let changed = app.overrides.contains_key(&p.name);
        let style = if i == app.selected {
            Style::default().add_modifier(Modifier::REVERSED)
        } else {
            Style::default()
        };
        lines.push(Line::from(vec![
            Span::styled(
                format!("{} ", if i == app.selected { '>' } else { ' ' }),
                style,
            ),
            Span::styled(format!("{:<11}", p.name), style.fg(Color::Cyan)),
            Span::styled(
                value,
                if changed {
                    style.fg(Color::Yellow)
                } else {
                    style
                },
            ),
        ]));
    }
    frame.render_widget(
        Paragraph::new(lines).block(Block::default().borders(Borders::ALL).title(" view ")),
        area,
    );
}

/// The keys' own changes to the last render, when there are any.
fn edit_lines(app: &App, key: Style) -> Vec<Line<'static>> {
    let e = &app.edit;
    let mut lines = Vec::new();
    if e.azimuth_deg != 0.0 || e.elevation_deg != 0.0 || e.zoom != 1.0 {
        lines.push(Line::from(vec![
            Span::styled("camera   ", key),
            Span::raw(format!(
                "az {:+}° el {:+}° ×{}",
                e.azimuth_deg,
                e.elevation_deg,
                format_number(e.zoom)
            )),
        ]));
    }
    if e.opacity_decades != 0.0 {
        lines.push(Line::from(vec![
            Span::styled("opacity  ", key),
            Span::raw(format!("{:+} decades", e.opacity_decades)),
        ]));
    }
    if let Some([lo, hi]) = e.lens {
        let surface = matches!(
            app.keys.as_ref().map(|k| k.target),
            Some(crate::tui::scene::KeyTarget::Surface { .. })
        );
        lines.push(Line::from(vec![
            Span::styled(if surface { "range    " } else { "window   " }, key),
            Span::raw(format!("[{}, {}]", format_number(lo), format_number(hi))),
        ]));
    }
    if e.nu_factor != 1.0 {
        lines.push(Line::from(vec![
            Span::styled("ν        ", key),
            Span::raw(format!("×{}", format_number(e.nu_factor))),
        ]));
    }
    if let Some(mode) = e.mode {
        lines.push(Line::from(vec![
            Span::styled("mode     ", key),
            Span::raw(mode.name()),
        ]));
    }
    lines
}

fn draw_histogram(frame: &mut Frame, app: &App, area: Rect) {
    let block = Block::default()
        .borders(Borders::ALL)
        .title(" log10 luminance ");
    let inner = block.inner(area);
    frame.render_widget(block, area);
    let lines = match &app.histogram {
        Some(h) => h.lines(
            app.view.exposure_ev,
            inner.width as usize,
            inner.height as usize,
        ),
        None => vec![Line::from("no positive luminance")],
    };
    frame.render_widget(Paragraph::new(lines), inner);
}

fn draw_status(frame: &mut Frame, app: &App, area: Rect) {
    let s = &app.status;
    let dim = Style::default().fg(Color::DarkGray);
    // Most important first: a narrow terminal cuts the line on the right.
    let mut segments: Vec<Span> = vec![Span::styled("? help", dim)];
    if s.busy {
        segments.push(Span::styled(
            "rendering…",
            Style::default().fg(Color::Yellow),
        ));
    }
    if !app.message.is_empty() {
        segments.push(Span::styled(
            app.message.clone(),
            Style::default().fg(Color::Green),
        ));
    }
    if !app.log_line.is_empty() {
        segments.push(Span::styled(
            format!("print: {}", app.log_line),
            Style::default().fg(Color::Magenta),
        ));
    }
    if !s.adapter.is_empty() {
        segments.push(Span::raw(s.adapter.clone()));
    }
    if let Some(ms) = s.render_ms {
        segments.push(Span::raw(format!("{} {ms:.0} ms", s.stage)));
    }
    if !s.passes.is_empty() {
        segments.push(Span::raw(format!("passes: {}", s.passes.join(", "))));
    }
    if !app.protocol_note.is_empty() {
        segments.push(Span::raw(app.protocol_note.clone()));
    }
    let mut parts = Vec::new();
    for (i, seg) in segments.into_iter().enumerate() {
        if i > 0 {
            parts.push(Span::styled(" │ ", dim));
        }
        parts.push(seg);
    }
    frame.render_widget(Paragraph::new(Line::from(parts)), area);
}

/// The help overlay: every key of [`KEYS`], in two columns when the screen is wide enough.
fn draw_help(frame: &mut Frame, area: Rect) {
    let entries: Vec<Line> = KEYS
        .iter()
        .map(|(keys, _, what)| {
            Line::from(vec![
                Span::styled(format!("{keys:<11}"), Style::default().fg(Color::Cyan)),
                Span::raw(*what),
            ])
        })
        .collect();
    let two_columns = area.width >= 100;
    let rows = if two_columns {
        entries.len().div_ceil(2)
    } else {
        entries.len()
    } as u16;
    let width = if two_columns {
        area.width.min(120) - 2
    } else {
        area.width.min(60)
    };
    let height = (rows + 2).min(area.height);
    let rect = Rect::new(
        area.x + (area.width - width) / 2,
        area.y + (area.height - height) / 2,
        width,
        height,
    );
    frame.render_widget(Clear, rect);
    let block = Block::default()
        .borders(Borders::ALL)
        .title(" keys (? or Esc closes) ");
    let inner = block.inner(rect);
    frame.render_widget(block, rect);
    if two_columns {
        let halves = Layout::default()
            .direction(Direction::Horizontal)
            .constraints([Constraint::Percentage(50), Constraint::Percentage(50)])
            .split(inner);
        let (a, b) = entries.split_at(rows as usize);
        frame.render_widget(Paragraph::new(a.to_vec()), halves[0]);
        frame.render_widget(Paragraph::new(b.to_vec()), halves[1]);
    } else {
        // On a short screen the list scrolls out of view rather than wrapping into a mess.
        frame.render_widget(Paragraph::new(entries).wrap(Wrap { trim: false }), inner);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::HdrImage;
    use crate::script::{ParamKind, ParamRecord};
    use crate::tui::histogram::LogHistogram;
    use ratatui::backend::TestBackend;
    use ratatui::buffer::Buffer;
    use ratatui::Terminal;
    use std::sync::Arc;

    fn screen(buf: &Buffer) -> Vec<String> {
        (0..buf.area.height)
            .map(|y| {
                (0..buf.area.width)
                    .map(|x| buf[(x, y)].symbol().to_string())
                    .collect::<String>()
            })
            .collect()
    }

    fn demo_app() -> App {
        let mut app = App::new(
            Source::Script("scripts/tui_demo.rhai".into()),
            "out".into(),
            Vec::new(),
        );
        let rec = |n: &str, v: &str| ParamRecord {
            name: n.into(),
            kind: ParamKind::Float,
            default: v.into(),
            value: v.into(),
        };
        app.set_params(vec![
            rec("azimuth", "35.0"),
            rec("elevation", "20.0"),
            rec("zoom", "1.0"),
            rec("lens_lo", "-12499999999999.0"),
        ]);
        app.view.exposure_ev = 0.5;
        let img = HdrImage::from_pixels(
            4,
            2,
            (0..8).map(|i| [i as f32 * 0.1, 0.2, 0.3, 1.0]).collect(),
        );
        app.histogram = LogHistogram::new(&img, 32);
        app.hdr = Some(Arc::new(img));
        app.status.adapter = "llvmpipe (Vulkan)".into();
        app.status.render_ms = Some(123.4);
        app.status.stage = "full".into();
        app.status.passes = vec!["volume 120 ms".into()];
        app.protocol_note = "halfblocks".into();
        app
    }

    fn render(app: &App, w: u16, h: u16, image: Option<&Picture>) -> Vec<String> {
        let mut term = Terminal::new(TestBackend::new(w, h)).unwrap();
        term.draw(|f| draw(f, app, image)).unwrap();
        screen(term.backend().buffer())
    }

    #[test]
    fn layout_at_80x24_puts_every_part_on_screen() {
        let a = layout(Rect::new(0, 0, 80, 24));
        assert_eq!(a.status, Rect::new(0, 23, 80, 1));
        assert_eq!(a.image_block, Rect::new(0, 0, 50, 23));
        assert_eq!(a.image, Rect::new(1, 1, 48, 21));
        assert_eq!(a.params, Rect::new(50, 0, 30, 15));
        assert_eq!(a.histogram, Rect::new(50, 15, 30, 8));
        // Narrow screens give the picture the whole width.
        let n = layout(Rect::new(0, 0, 40, 12));
        assert_eq!(n.image_block.width, 40);
        assert_eq!(n.params.width, 0);
    }

    #[test]
    fn snapshot_80x24_panel_histogram_and_status() {
        let lines = render(&demo_app(), 80, 24, None);
        let expect_prefix = [(0, "┌ tui_demo.rhai ─"), (1, "│no image")];
        for (row, prefix) in expect_prefix {
            assert!(
                lines[row].starts_with(prefix),
                "row {row}: {:?}",
                lines[row]
            );
        }
        assert_eq!(
            &lines[0][..],
            format!(
                "┌ tui_demo.rhai {}┐┌ view {}┐",
                "─".repeat(33),
                "─".repeat(22)
            )
        );
        assert_eq!(
            lines[1].chars().skip(50).collect::<String>(),
            "│exposure +0.5 EV            │"
        );
        assert_eq!(
            lines[2].chars().skip(50).collect::<String>(),
            "│operator exposure           │"
        );
        assert_eq!(
            lines[3].chars().skip(50).collect::<String>(),
            "│channel  RGB                │"
        );
        assert_eq!(
            lines[4].chars().skip(50).collect::<String>(),
            "│image    4×2 full           │"
        );
        assert_eq!(
            lines[6].chars().skip(50).collect::<String>(),
            "│> azimuth    35             │"
        );
        assert_eq!(
            lines[7].chars().skip(50).collect::<String>(),
            "│  elevation  20             │"
        );
        assert!(lines[15].contains("log10 luminance"));
        assert!(
            lines[21].contains("window"),
            "histogram label row: {:?}",
            lines[21]
        );
        assert_eq!(
            lines[23].trim_end(),
            "? help │ llvmpipe (Vulkan) │ full 123 ms │ passes: volume 120 ms │ halfblocks"
        );
    }

    #[test]
    fn script_error_shows_line_and_caret_over_the_kept_image() {
        let mut app = demo_app();
        app.error = Some(crate::script::format_error(
            "s.rhai",
            "let a = 1;\nlet b = nope(a);\n",
            "function not found: nope",
            rhai::Position::new(2, 9),
        ));
        let lines = render(&app, 80, 24, None);
        let text = lines.join("\n");
        assert!(text.contains("script error (last good image kept)"));
        assert!(text.contains("s.rhai:2:9: function not found: nope"));
        let src_row = lines
            .iter()
            .position(|l| l.contains("let b = nope(a);"))
            .unwrap();
        // The caret sits under column 9 of the source line ("  " indent from format_error).
        let src_col = lines[src_row].find("let b").unwrap();
        let caret_col = lines[src_row + 1].find('^').unwrap();
        assert_eq!(caret_col, src_col + 8);
    }

    #[test]
    fn help_overlay_lists_every_key() {
        let mut app = demo_app();
        app.show_help = true;
        for (w, h) in [(100, 40), (80, 40)] {
            let text = render(&app, w, h, None).join("\n");
            for (keys, _, what) in KEYS {
                assert!(text.contains(keys), "{w}x{h}: missing {keys}");
                assert!(text.contains(what), "{w}x{h}: missing {what}");
            }
        }
    }

    #[test]
    fn halfblock_picture_lands_in_the_image_area_with_its_colours() {
        use ratatui_image::picker::Picker;
        let app = demo_app();
        let areas = layout(Rect::new(0, 0, 80, 24));
        // A 2-colour picture: red top half, blue bottom half, exactly the area's size in
        // halfblock pixels (1 × 2 per cell at the picker's nominal 10 × 20 font).
        let picker = Picker::halfblocks();
        let fs = picker.font_size();
        let (w, h) = (
            areas.image.width as u32 * fs.width as u32,
            areas.image.height as u32 * fs.height as u32,
        );
        let img = image::RgbImage::from_fn(w, h, |_, y| {
            if y < h / 2 {
                image::Rgb([255, 0, 0])
            } else {
                image::Rgb([0, 0, 255])
            }
        });
        let protocol = picker
            .new_protocol(
                image::DynamicImage::ImageRgb8(img),
                areas.image.as_size(),
                ratatui_image::Resize::Fit(None),
            )
            .unwrap();
        let mut term = Terminal::new(TestBackend::new(80, 24)).unwrap();
        let picture = Picture::Widget(protocol);
        term.draw(|f| draw(f, &app, Some(&picture))).unwrap();
        let buf = term.backend().buffer();
        let top = &buf[(areas.image.x + 3, areas.image.y + 1)];
        let bottom = &buf[(areas.image.x + 3, areas.image.bottom() - 2)];
        assert_eq!(top.fg, Color::Rgb(255, 0, 0));
        assert_eq!(bottom.fg, Color::Rgb(0, 0, 255));
        // The panel is untouched by the picture.
        assert_eq!(
            screen(buf)[1].chars().skip(50).collect::<String>(),
            "│exposure +0.5 EV            │"
        );
    }
}
