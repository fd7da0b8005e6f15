//! The report's figure model: plots of series, pictures, tables, sections;
//! every number drawn is kept in them, so figures.json is the page's data.
use crate::error::Result;
use crate::image_io::{encode_png, write_atomic};
use glam::Vec3A as V3;
use serde::Serialize;
use std::path::PathBuf;

/// One curve of a plot; `spread` (optional) is a [low, high] bar per point.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct Series {
    /// Legend entry.
    pub name: String,
    /// `[x, y]` in the plot's units, in drawing order.
    pub points: Vec<[f64; 2]>,
    /// `[low, high]` per point (e.g. fastest..slowest repetition), drawn as a bar.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub spread: Option<Vec<[f64; 2]>>,
}

/// A plot: every number it draws is in its series.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct Plot {
    /// Key of the plot in figures.json and its anchor in the page.
    pub id: String,
    /// Caption drawn above the plot.
    pub title: String,
    /// Label of the x axis, with its unit.
    pub x: String,
    /// Label of the y axis, with its unit.
    pub y: String,
    /// Logarithmic x axis.
    pub log_x: bool,
    /// Logarithmic y axis.
    pub log_y: bool,
    /// The curves (empty ones are dropped).
    pub series: Vec<Series>,
}

/// An image written beside the page.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct Picture {
    /// File name of the PNG, relative to the report directory.
    pub file: String,
    /// Caption under the image.
    pub caption: String,
}

/// A table shown under a section's plots.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct Table {
    /// Column titles.
    pub header: Vec<String>,
    /// Cells, already formatted, one `Vec` per row.
    pub rows: Vec<Vec<String>>,
}

/// One section of the report.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct Section {
    /// Key of the section in figures.json (`convergence`, `nested`, …).
    pub key: String,
    /// Heading in the page.
    pub title: String,
    /// One-line findings, shown at the top of the section.
    pub summary: Vec<String>,
    /// The section's plots, in page order.
    pub plots: Vec<Plot>,
    /// The section's images, in page order.
    pub pictures: Vec<Picture>,
    /// An optional table under the plots.
    pub table: Option<Table>,
}

/// A series without spread bars.
pub(crate) fn series(name: impl Into<String>, points: Vec<[f64; 2]>) -> Series {
    Series {
        name: name.into(),
        points,
        spread: None,
    }
}

/// A plot of `series` (empty ones dropped); `log` is (x, y) logarithmic.
pub(crate) fn plot(id: &str, title: &str, x: &str, y: &str, log: (bool, bool), series: Vec<Series>) -> Plot {
    Plot {
        id: id.into(),
        title: title.into(),
        x: x.into(),
        y: y.into(),
        log_x: log.0,
        log_y: log.1,
        series: series.into_iter().filter(|s| !s.points.is_empty()).collect(),
    }
}

/// The report's directory, where pictures are written beside the page.
pub(crate) struct ReportDir {
    pub dir: PathBuf,
}

impl ReportDir {
    /// Write `px` (`w`×`h`) as `name` (a PNG) and describe it for the page.
    pub fn png(&self, name: &str, w: u32, h: u32, px: &[V3], caption: String) -> Result<Picture> {
        write_atomic(&self.dir.join(name), &encode_png(w, h, px)?)?;
        Ok(Picture {
            file: name.into(),
            caption,
        })
    }
}
