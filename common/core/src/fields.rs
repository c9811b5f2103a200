//! Range checks of config fields that name the field by its full path (`table.field`),
//! once, so that every config table reports a bad value the same way.

use std::fmt::Display;

/// A config value outside its range.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{field} = {value} is out of range: expected {expected}")]
pub struct FieldError {
    /// Full path of the field (`lines.grid.cell_size`).
    pub field: String,
    /// The value, as written.
    pub value: String,
    /// The accepted range, in words.
    pub expected: String,
}

/// The checks of one table (`path` is its dotted name: `mapping.ba`).
#[derive(Clone, Copy, Debug)]
pub struct Table<'a>(pub &'a str);

impl Table<'_> {
    /// `Ok` when `ok`, else the error naming `path.name = value`.
    ///
    /// # Errors
    /// [`FieldError`] when not `ok`.
    pub fn require(
        &self,
        name: &str,
        value: impl Display,
        ok: bool,
        expected: &str,
    ) -> Result<(), FieldError> {
        if ok {
            return Ok(());
        }
        Err(FieldError {
            field: format!("{}.{name}", self.0),
            value: value.to_string(),
            expected: expected.to_owned(),
        })
    }

    /// A finite value above 0.
    ///
    /// # Errors
    /// [`FieldError`] otherwise.
    pub fn positive(&self, name: &str, value: f64) -> Result<(), FieldError> {
        self.require(name, value, value.is_finite() && value > 0.0, "finite, > 0")
    }

    /// A finite value of at least `min`.
    ///
    /// # Errors
    /// [`FieldError`] otherwise.
    pub fn not_below(&self, name: &str, value: f64, min: f64) -> Result<(), FieldError> {
        self.require(
            name,
            value,
            value.is_finite() && value >= min,
            &format!("finite, >= {min}"),
        )
    }

    /// A finite value in `[lo, hi]`.
    ///
    /// # Errors
    /// [`FieldError`] otherwise.
    pub fn within(&self, name: &str, value: f64, lo: f64, hi: f64) -> Result<(), FieldError> {
        self.require(
            name,
            value,
            value.is_finite() && (lo..=hi).contains(&value),
            &format!("in [{lo}, {hi}]"),
        )
    }

    /// A fraction in `(0, 1]`.
    ///
    /// # Errors
    /// [`FieldError`] otherwise.
    pub fn fraction(&self, name: &str, value: f64) -> Result<(), FieldError> {
        self.require(name, value, value > 0.0 && value <= 1.0, "in (0, 1]")
    }

    /// A count of at least `min`.
    ///
    /// # Errors
    /// [`FieldError`] otherwise.
    pub fn at_least(&self, name: &str, value: u64, min: u64) -> Result<(), FieldError> {
        self.require(name, value, value >= min, &format!(">= {min}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn errors_name_the_full_path_once() {
        let t = Table("lines.grid");
        assert!(t.at_least("cell_size", 4, 1).is_ok());
        let e = t.at_least("cell_size", 0, 1).unwrap_err().to_string();
        assert_eq!(e, "lines.grid.cell_size = 0 is out of range: expected >= 1");
        assert!(Table("depth").positive("scale", f64::NAN).is_err());
        assert!(Table("depth").positive("scale", 0.0).is_err());
        assert!(Table("a").fraction("r", 1.0).is_ok());
        assert!(Table("a").fraction("r", 0.0).is_err());
        assert!(Table("a").within("x", 2.0, 0.0, 1.0).is_err());
    }
}
