//! `report.html`: the report's tables (the page views of the [`Table`] models the CSV files are
//! written from), its plots and its prose, rendered by the tera templates in `templates/report/`
//! (compiled in).
//!
//! In: the [`Report`], its tables and the plots' (file, caption). Out: the page text.
//! **Invariants:** autoescaping is on, so text from the data (a group named `<script>`) is never
//! markup; tables come only from the models (no table is formatted here); same input, same bytes.

use serde::Serialize;
use tera::{Context, Kwargs, State, Tera, TeraResult, Value};

use super::table::{PageTable, Table};
use super::tables::slug;
use super::{Report, ReportError};
use crate::analysis::rating::RatingReport;

const TEMPLATES: [(&str, &str); 2] = [
    ("report/components.html", include_str!("../../templates/report/components.html")),
    ("report/report.html", include_str!("../../templates/report/report.html")),
];

/// A plot: its PNG file beside the page and its caption.
#[derive(Debug, Clone, Serialize)]
pub(super) struct Figure {
    pub file: String,
    pub caption: String,
}

#[derive(Serialize)]
struct CodingPage {
    table1: Option<PageTable>,
    per_au: Option<PageTable>,
    f1_plot: Option<Figure>,
    table4: Option<PageTable>,
    agreement: Option<PageTable>,
    au_level: Option<PageTable>,
}

#[derive(Serialize)]
struct ConditionPage {
    confusion: Option<PageTable>,
    average_rate: Option<f64>,
    accuracy: Option<f64>,
    recognition: Option<PageTable>,
    plot: Option<Figure>,
}

#[derive(Serialize)]
struct RatingPage {
    conditions: Vec<ConditionPage>,
    table11: Option<PageTable>,
    icc: Option<PageTable>,
    design: DesignPage,
    believability_plot: Option<Figure>,
    anova: Option<PageTable>,
    group_tests: Option<PageTable>,
    table14: Option<PageTable>,
}

/// The statistics the design calls for (tables without rows are absent).
#[derive(Serialize)]
struct DesignPage {
    rm_anova: Option<PageTable>,
    paired: Option<PageTable>,
    between: Option<PageTable>,
    post_hoc: Option<PageTable>,
}

/// Seed 004's studies: ratings by label × style.
#[derive(Serialize)]
struct StylesPage {
    convention: &'static str,
    means: Option<PageTable>,
    plots: Vec<Figure>,
    anova: Option<PageTable>,
    scheffe: Option<PageTable>,
}

/// What the template gets: the report (for the prose) and the tables' page views.
#[derive(Serialize)]
struct Page<'a> {
    report: &'a Report,
    coding: Option<CodingPage>,
    demographics: Option<PageTable>,
    rating: Option<RatingPage>,
    styles: Option<StylesPage>,
}

/// The page views of the tables, found by CSV file name.
struct Views<'a> {
    tables: &'a [Table],
    plots: &'a [Figure],
}

impl Views<'_> {
    /// The page view of `file` restricted by `also`; `None` without the table or without rows.
    fn table(&self, file: &str, also: &[(&str, &str)]) -> Result<Option<PageTable>, ReportError> {
        let Some(table) = self.tables.iter().find(|t| t.file == file) else { return Ok(None) };
        Ok(table.page(also)?.filter(|p| !p.rows.is_empty()))
    }

    fn plot(&self, file: &str) -> Option<Figure> {
        self.plots.iter().find(|f| f.file == file).cloned()
    }

    fn coding(&self) -> Result<CodingPage, ReportError> {
        Ok(CodingPage {
            table1: self.table("table1_grouped.csv", &[])?,
            per_au: self.table("table1_3_per_au.csv", &[])?,
            f1_plot: self.plot("plot_f1_per_au.png"),
            table4: self.table("table4_combinations.csv", &[])?,
            agreement: self.table("coder_agreement.csv", &[])?,
            au_level: self.table("au_level_comparison.csv", &[])?,
        })
    }

    fn styles(&self, report: &Report) -> Result<StylesPage, ReportError> {
        Ok(StylesPage {
            convention: crate::analysis::styles::CONVENTION,
            means: self.table("styles_means.csv", &[])?,
            plots: report.styles.iter().filter_map(|s| self.plot(&format!("plot_styles_{}.png", s.scale.name()))).collect(),
            anova: self.table("styles_anova.csv", &[])?,
            scheffe: self.table("styles_scheffe.csv", &[])?,
        })
    }

    fn rating(&self, r: &RatingReport) -> Result<RatingPage, ReportError> {
        let mut conditions = Vec::new();
        for c in r.conditions.iter().filter(|c| c.confusion.is_some()) {
            let slug = slug(&c.key);
            conditions.push(ConditionPage {
                confusion: self.table(&format!("confusion_{slug}_percent.csv"), &[])?,
                average_rate: c.average_rate,
                accuracy: c.accuracy,
                recognition: self.table("recognition.csv", &[("condition", &c.key)])?,
                plot: self.plot(&format!("plot_confusion_{slug}.png")),
            });
        }
        Ok(RatingPage {
            conditions,
            table11: self.table("table11_ratings.csv", &[])?,
            icc: self.table("icc.csv", &[])?,
            design: DesignPage {
                rm_anova: self.table("rm_anova_emotion.csv", &[])?,
                paired: self.table("paired_tests.csv", &[])?,
                between: self.table("anova_between_conditions.csv", &[])?,
                post_hoc: self.table("post_hoc_conditions.csv", &[])?,
            },
            believability_plot: self.plot("plot_believability.png"),
            anova: self.table("anova.csv", &[])?,
            group_tests: self.table("group_tests.csv", &[])?,
            table14: self.table("table14_comparison.csv", &[])?,
        })
    }
}

/// `{{ x | fixed(decimals=2, scale=1) }}`: a number with a fixed count of decimals; `–` for none.
fn fixed(value: &Value, kwargs: Kwargs, _: &State) -> TeraResult<String> {
    let decimals = kwargs.get::<i64>("decimals")?.unwrap_or(2).clamp(0, 12) as usize;
    let scale = kwargs.get::<f64>("scale")?.unwrap_or(1.0);
    Ok(value.as_f64().map_or_else(|| "–".to_string(), |v| format!("{:.decimals$}", scale * v)))
}

fn templates() -> Result<Tera, ReportError> {
    let mut tera = Tera::new();
    tera.autoescape_on([".html"]);
    tera.register_filter("fixed", fixed);
    tera.add_raw_templates(TEMPLATES).map_err(|e| ReportError::Page { detail: e.to_string() })?;
    Ok(tera)
}

/// The whole page: the inputs, then one section per part of the report.
pub(super) fn page(report: &Report, tables: &[Table], plots: &[Figure]) -> Result<String, ReportError> {
    let views = Views { tables, plots };
    let coding = report.coding.as_ref().map(|_| views.coding()).transpose()?;
    let rating = report.rating.as_ref().map(|r| views.rating(r)).transpose()?;
    let demographics = views.table("table6_demographics.csv", &[])?;
    let styles = (!report.styles.is_empty()).then(|| views.styles(report)).transpose()?;
    let page = Page { report, coding, demographics, rating, styles };
    let context = Context::from_serialize(&page).map_err(|e| ReportError::Page { detail: e.to_string() })?;
    templates()?.render("report/report.html", &context).map_err(|e| ReportError::Page { detail: e.to_string() })
}
