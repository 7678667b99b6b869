//! Why a plot cannot be drawn ([`PlotError`]).

use super::*;

/// Why a plot cannot be drawn.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The bundled font, which plotters cannot register.
    #[error("the bundled font cannot be read")]
    Font,
    /// Plotters cannot draw the plot.
    #[error("{}: cannot draw the plot: {source}", path.display())]
    Draw {
        /// The plot's file.
        path: PathBuf,
        /// Plotters' reason.
        #[source]
        source: DrawError,
    },
    /// A drawn bitmap of another size than the plot's.
    #[error("plot buffer size")]
    Buffer,
}

/// `v` as a message shows it: plain up to 10¹⁵, in exponent form for the
/// huge and the tiny (1e308 is not written out in 309 digits).
/// An `f32` is written as its own shortest form (1e30, not the nearest f64).
pub fn number<T: Into<f64> + Copy + fmt::Display + fmt::LowerExp>(v: T) -> String {
    let x: f64 = v.into();
    if x != 0.0 && x.is_finite() && !(1e-4..1e15).contains(&x.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}
