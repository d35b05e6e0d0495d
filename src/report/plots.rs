//! PNG plots drawn with plotters into memory (embedded DejaVu Sans, no system fonts).

use std::sync::Once;

use plotters::prelude::*;
use plotters::style::FontStyle;

use super::{Report, ReportError};
use crate::analysis::power::{PowerRow, PowerTable};
use crate::engine::image::RgbImage;

const FONT: &str = "facslab-sans";
static REGISTER: Once = Once::new();

fn register_font() {
    REGISTER.call_once(|| {
        let bytes: &'static [u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");
        plotters::style::register_font(FONT, FontStyle::Normal, bytes).unwrap_or_else(|_| panic!("the embedded font is valid"));
    });
}

fn font(size: f64) -> TextStyle<'static> {
    (FONT, size).into_font().color(&BLACK)
}

fn plot_err(name: &str) -> impl Fn(String) -> ReportError + '_ {
    move |detail| ReportError::Plot { name: name.to_string(), detail }
}

/// Draws with `draw` into a `w`×`h` white canvas and encodes it as PNG.
fn draw_png(name: &str, w: u32, h: u32, draw: impl FnOnce(&DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>) -> Result<(), String>) -> Result<Vec<u8>, ReportError> {
    register_font();
    let mut image = RgbImage::new(w, h);
    {
        let root = BitMapBackend::with_buffer(&mut image.data, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| plot_err(name)(e.to_string()))?;
        draw(&root).map_err(plot_err(name))?;
        root.present().map_err(|e| plot_err(name)(e.to_string()))?;
    }
    Ok(image.encode_png())
}

fn heat(p: f64) -> RGBColor {
    // White to a dark blue, linear in percent.
    let t = (p / 100.0).clamp(0.0, 1.0);
    let lerp = |a: f64, b: f64| (a + (b - a) * t).round() as u8;
    RGBColor(lerp(255.0, 8.0), lerp(255.0, 69.0), lerp(255.0, 148.0))
}

fn short(label: &str) -> String {
    cut(label, 8)
}

/// `label` capitalised, cut to `chars` characters (a dot marks the cut).
fn cut(label: &str, chars: usize) -> String {
    let mut s: String = label.chars().take(chars).collect();
    if label.chars().count() > chars {
        s.push('.');
    }
    let mut c = s.chars();
    c.next().map(|f| f.to_uppercase().collect::<String>() + c.as_str()).unwrap_or_default()
}

fn confusion(name: &str, title: &str, rows: &[String], cols: &[String], percent: &[Vec<f64>]) -> Result<Vec<u8>, ReportError> {
    let (cell, left, top) = (58i32, 110i32, 80i32);
    let w = (left + cell * cols.len() as i32 + 20) as u32;
    let h = (top + cell * rows.len() as i32 + 40) as u32;
    draw_png(name, w, h, |root| {
        let e = |e: DrawingAreaErrorKind<_>| e.to_string();
        root.draw(&Text::new(title.to_string(), (10, 8), font(18.0))).map_err(e)?;
        root.draw(&Text::new("chosen label →".to_string(), (left, 32), font(13.0))).map_err(e)?;
        for (j, c) in cols.iter().enumerate() {
            let x = left + j as i32 * cell + 4;
            root.draw(&Text::new(short(c), (x, top - 22), font(11.5))).map_err(e)?;
        }
        for (i, r) in rows.iter().enumerate() {
            let y = top + i as i32 * cell;
            root.draw(&Text::new(short(r), (8, y + cell / 2 - 7), font(13.0))).map_err(e)?;
            for (j, &p) in percent[i].iter().enumerate() {
                let x = left + j as i32 * cell;
                root.draw(&Rectangle::new([(x, y), (x + cell - 2, y + cell - 2)], heat(p).filled())).map_err(e)?;
                let colour = if p > 55.0 { WHITE } else { BLACK };
                let text = format!("{p:.1}");
                root.draw(&Text::new(text, (x + 10, y + cell / 2 - 7), ("facslab-sans", 13.0).into_font().color(&colour))).map_err(e)?;
            }
        }
        root.draw(&Text::new("rows: shown emotion; cells: percent of the row".to_string(), (10, h as i32 - 24), font(12.0))).map_err(e)?;
        Ok(())
    })
}

fn f1_bars(name: &str, aus: &[u16], f1: &[f64]) -> Result<Vec<u8>, ReportError> {
    let w = (160 + 22 * aus.len()).max(500) as u32;
    draw_png(name, w, 380, |root| {
        let mut chart = ChartBuilder::on(root)
            .caption("F1 per AU (coders vs ground truth)", font(18.0))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(48)
            .build_cartesian_2d(-0.5f64..aus.len() as f64 - 0.5, 0f64..1.05f64)
            .map_err(|e| e.to_string())?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .max_light_lines(0)
            .x_labels(aus.len())
            .x_label_formatter(&|x| {
                let i = x.round();
                if (x - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < aus.len() { aus[i as usize].to_string() } else { String::new() }
            })
            .y_desc("F1")
            .x_desc("AU")
            .label_style(font(11.0))
            .axis_desc_style(font(13.0))
            .draw()
            .map_err(|e| e.to_string())?;
        chart
            .draw_series(f1.iter().enumerate().map(|(i, &v)| {
                let colour = if v >= 0.8 { RGBColor(49, 130, 189) } else { RGBColor(230, 85, 13) };
                Rectangle::new([(i as f64 - 0.38, 0.0), (i as f64 + 0.38, v)], colour.filled())
            }))
            .map_err(|e| e.to_string())?;
        Ok(())
    })
}

/// A series' name and its mean ± SD point per label (`None` where the label has none).
type RatingSeries = (String, Vec<Option<(f64, f64)>>);

/// Mean ± SD points per label (x) and series (colour): believability per emotion and condition,
/// or seed 004's ratings per type and style (Fig. 8, Fig. 10).
/// `wide`: room for names of up to 17 characters (the laugh types) instead of 8.
fn rating_points(name: &str, title: &str, labels: &[String], series: &[RatingSeries], wide: bool) -> Result<Vec<u8>, ReportError> {
    let palette = [RGBColor(49, 130, 189), RGBColor(158, 202, 225), RGBColor(230, 85, 13), RGBColor(253, 174, 107), RGBColor(49, 163, 84)];
    let (per_label, chars) = if wide { (105, 17) } else { (70, 8) };
    let w = (200 + per_label * labels.len()).max(600) as u32;
    // Studies ask 1-5 (the default) or 0-5 (HapFACS's reading): the axis starts at 0 only when a
    // mean minus its SD goes below 1.
    let lowest = series.iter().flat_map(|(_, points)| points.iter().flatten()).map(|(mean, sd)| mean - sd).fold(f64::INFINITY, f64::min);
    let y_min = if lowest < 1.0 { -0.5 } else { 0.5 };
    draw_png(name, w, 420, |root| {
        let mut chart = ChartBuilder::on(root)
            .caption(title, font(18.0))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(48)
            .build_cartesian_2d(-0.5f64..labels.len() as f64 - 0.5, y_min..5.5f64)
            .map_err(|e| e.to_string())?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .max_light_lines(0)
            .x_labels(labels.len())
            .x_label_formatter(&|x| {
                let i = x.round();
                if (x - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < labels.len() { cut(&labels[i as usize], chars) } else { String::new() }
            })
            .y_desc("rating")
            .label_style(font(11.0))
            .axis_desc_style(font(13.0))
            .draw()
            .map_err(|e| e.to_string())?;
        let k = series.len().max(1) as f64;
        for (si, (cond, points)) in series.iter().enumerate() {
            let colour = palette[si % palette.len()];
            let dx = -0.3 + 0.6 * (si as f64 + 0.5) / k;
            chart
                .draw_series(points.iter().enumerate().filter_map(|(i, p)| {
                    p.map(|(m, sd)| ErrorBar::new_vertical(i as f64 + dx, m - sd, m, m + sd, colour.stroke_width(2), 8))
                }))
                .map_err(|e| e.to_string())?
                .label(cond.clone())
                .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], colour.filled()));
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK)
            .label_font(font(12.0))
            .position(SeriesLabelPosition::LowerRight)
            .draw()
            .map_err(|e| e.to_string())?;
        Ok(())
    })
}

/// One line of the power plot: a label and its (size, value) points.
type Series = (String, Vec<(f64, f64)>);

/// The (size, value) points of the `mean` rows (or the only row) of each statistic.
fn power_series(table: &PowerTable, value: fn(&PowerRow) -> Option<f64>) -> Vec<Series> {
    let mut statistics: Vec<&str> = Vec::new();
    for r in &table.rows {
        if !statistics.contains(&r.statistic.as_str()) {
            statistics.push(&r.statistic);
        }
    }
    statistics
        .into_iter()
        .map(|s| {
            let rows: Vec<&PowerRow> = table.rows.iter().filter(|r| r.statistic == s).collect();
            let headline = |r: &&&PowerRow| r.item == "mean" || !rows.iter().any(|x| x.item == "mean");
            (s.to_string(), rows.iter().filter(headline).filter_map(|r| Some((r.size as f64, value(r)?))).collect())
        })
        .filter(|(_, points): &Series| !points.is_empty())
        .collect()
}

/// One panel of the power plot: a line with dots per series, and optionally crosses for a
/// second value of the same series.
fn power_panel(area: &DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>, title: &str, y_desc: &str, x_max: f64, lines: &[Series], crosses: &[Series]) -> Result<(), String> {
    let palette = [RGBColor(49, 130, 189), RGBColor(230, 85, 13), RGBColor(49, 163, 84), RGBColor(117, 107, 177)];
    let y_max = lines.iter().chain(crosses).flat_map(|(_, p)| p.iter().map(|q| q.1)).fold(0.0f64, f64::max).max(0.05) * 1.15;
    let mut chart = ChartBuilder::on(area).caption(title, font(16.0)).margin(12).x_label_area_size(40).y_label_area_size(52).build_cartesian_2d(0f64..x_max * 1.05, 0f64..y_max).map_err(|e| e.to_string())?;
    chart.configure_mesh().max_light_lines(0).x_desc("sample size").y_desc(y_desc).label_style(font(11.0)).axis_desc_style(font(13.0)).draw().map_err(|e| e.to_string())?;
    for (i, (label, points)) in lines.iter().enumerate() {
        let colour = palette[i % palette.len()];
        chart.draw_series(std::iter::once(PathElement::new(points.clone(), colour.stroke_width(2)))).map_err(|e| e.to_string())?.label(label.clone()).legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], colour.filled()));
        chart.draw_series(points.iter().map(|&p| Circle::new(p, 4, colour.filled()))).map_err(|e| e.to_string())?;
        if let Some((_, marks)) = crosses.iter().find(|(l, _)| l == label) {
            chart.draw_series(marks.iter().map(|&p| Cross::new(p, 6, colour.stroke_width(2)))).map_err(|e| e.to_string())?;
        }
    }
    chart.configure_series_labels().background_style(WHITE.mix(0.9)).border_style(BLACK).label_font(font(12.0)).position(SeriesLabelPosition::UpperRight).draw().map_err(|e| e.to_string())?;
    Ok(())
}

/// `power.png`: mean 95 % CI width per statistic against size (line and dots), the 2.5–97.5 %
/// spread of the estimates (crosses), and, when a t-test was simulated, its power.
pub(super) fn power(table: &PowerTable) -> Result<Vec<u8>, ReportError> {
    let widths = power_series(table, |r| r.ci_width_mean);
    let spreads = power_series(table, |r| Some(r.spread_width));
    let powers = power_series(table, |r| r.power);
    let x_max = table.sizes.iter().copied().max().unwrap_or(1) as f64;
    let w = if powers.is_empty() { 640 } else { 1200 };
    draw_png("power.png", w, 440, |root| {
        let (left, right) = if powers.is_empty() { (root.clone(), None) } else { let (l, r) = root.split_horizontally(680); (l, Some(r)) };
        power_panel(&left, "95% CI width (line) and spread of estimates (×)", "width", x_max, &widths, &spreads)?;
        if let Some(right) = right {
            let title = if table.rows.iter().any(|r| r.statistic.ends_with("t-test")) { format!("t-test power, difference {}", table.group_difference) } else { "power of the F-tests (p < .05)".to_string() };
            power_panel(&right, &title, "power", x_max, &powers, &[])?;
        }
        Ok(())
    })
}

/// Every plot: (file name, PNG bytes, caption).
pub(super) fn all(report: &Report) -> Result<Vec<(String, Vec<u8>, String)>, ReportError> {
    let mut out = Vec::new();
    if let Some(c) = &report.coding {
        let aus: Vec<u16> = c.per_au.iter().map(|r| r.au).collect();
        let f1: Vec<f64> = c.per_au.iter().map(|r| r.metrics.f1).collect();
        let name = "plot_f1_per_au.png".to_string();
        out.push((name.clone(), f1_bars(&name, &aus, &f1)?, "F1 per AU over all (coder, stimulus) pairs; orange: F1 < 0.8.".into()));
    }
    if let Some(r) = &report.rating {
        for cond in &r.conditions {
            if let Some(conf) = &cond.confusion {
                let name = format!("plot_confusion_{}.png", super::tables::slug(&cond.key));
                let title = format!("Emotion recognition, {} stimuli (percent)", cond.key);
                out.push((name.clone(), confusion(&name, &title, &conf.rows, &conf.columns, &conf.percent)?, format!("Confusion matrix, {}.", cond.key)));
            }
        }
        let labels: Vec<String> = r.labels.iter().filter(|l| *l != "none").cloned().collect();
        let series: Vec<RatingSeries> = r
            .conditions
            .iter()
            .filter_map(|c| {
                let s = c.scales.iter().find(|s| s.scale == crate::analysis::responses::Scale::Believability)?;
                let points = labels
                    .iter()
                    .map(|l| {
                        let d = s.cells.iter().find(|x| &x.emotion == l)?.stats.as_ref()?;
                        Some((d.mean, d.sd.unwrap_or(0.0)))
                    })
                    .collect();
                Some((c.key.clone(), points))
            })
            .collect();
        if !series.is_empty() {
            let name = "plot_believability.png".to_string();
            let title = "Believability: mean ± SD per emotion and condition";
            out.push((name.clone(), rating_points(&name, title, &labels, &series, false)?, "Believability: mean with ±1 SD error bars.".into()));
        }
    }
    for s in &report.styles {
        let series: Vec<RatingSeries> = s
            .styles
            .iter()
            .map(|style| {
                let point = |label: &String| s.cells.iter().find(|c| &c.label == label && &c.style == style)?.stats.as_ref().map(|d| (d.mean, d.sd.unwrap_or(0.0)));
                (style.clone(), s.labels.iter().map(point).collect())
            })
            .collect();
        let name = format!("plot_styles_{}.png", s.scale.name());
        let title = format!("{}: mean ± SD per label and style", s.scale.name());
        let set = crate::study::labels::LabelSet::named(&s.label_set);
        let names: Vec<String> = s.labels.iter().map(|l| set.map_or_else(|| l.clone(), |set| set.display(l))).collect();
        out.push((name.clone(), rating_points(&name, &title, &names, &series, true)?, format!("{}: mean with ±1 SD error bars per label, one colour per style (seed 004 Fig. 8 / Fig. 10).", s.scale.name())));
    }
    Ok(out)
}
