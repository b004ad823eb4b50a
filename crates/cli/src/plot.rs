//! PNG plots, drawn with plotters and the DejaVu font bundled by the `dejavu` crate (so no
//! system font library is needed).

use std::path::Path;

use anyhow::{anyhow, Result};
use hooke_core::Real;
use plotters::prelude::*;

fn register_font() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        // Registration only fails for a malformed font, and this one is a fixed, valid file.
        let _ = plotters::style::register_font(
            "sans-serif",
            FontStyle::Normal,
            dejavu::sans::regular(),
        );
    });
}

/// Measured against target Poisson's ratio, with the theoretical line (the paper's Fig. 7).
pub fn nu_sweep(path: &Path, title: &str, three_d: bool, points: &[(Real, Real)]) -> Result<()> {
    register_font();
    let (lo, hi) = if three_d { (-1.0, 0.5) } else { (-1.0, 1.0) };
    // The encoder picks the format from the extension, so the temporary name ends in .png.
    let tmp = path.with_extension("partial.png");
    {
        let root = BitMapBackend::new(&tmp, (800, 640)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| anyhow!("{e}"))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 22))
            .margin(16)
            .x_label_area_size(50)
            .y_label_area_size(60)
            .build_cartesian_2d(lo..hi, lo..hi)
            .map_err(|e| anyhow!("{e}"))?;
        chart
            .configure_mesh()
            .x_desc("target nu")
            .y_desc("measured nu")
            .label_style(("sans-serif", 16))
            .draw()
            .map_err(|e| anyhow!("{e}"))?;
        // Theory: the closed forms of q(nu) make the lattice's nu equal the target exactly.
        let curve = vec![(lo, lo), (hi, hi)];
        chart
            .draw_series(LineSeries::new(curve, RED.stroke_width(2)))
            .map_err(|e| anyhow!("{e}"))?
            .label("theory")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED.stroke_width(2)));
        chart
            .draw_series(
                points
                    .iter()
                    .map(|&(t, m)| Circle::new((t, m), 5, BLUE.filled())),
            )
            .map_err(|e| anyhow!("{e}"))?
            .label("measured (block test)")
            .legend(|(x, y)| Circle::new((x + 10, y), 5, BLUE.filled()));
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .label_font(("sans-serif", 16))
            .draw()
            .map_err(|e| anyhow!("{e}"))?;
        root.present().map_err(|e| anyhow!("{e}"))?;
    }
    std::fs::rename(&tmp, path)?;
    Ok(())
}
