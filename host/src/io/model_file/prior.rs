//! The `[prior]` table of a model file (this project's extension): the
//! scale of the D-H length and angle errors, in the file's units on file,
//! SI in the [`Prior`].

use armcal_shared::units::Units;
use toml::de::{DeTable, DeValue};

use super::keys::{PRIOR_KEYS, a_type};
use super::reader::ModelReader;
use crate::session::input_error::InputError;
use crate::session::prior::Prior;

impl ModelReader<'_> {
    /// `[prior]`: the scale of a D-H length and angle error (one standard
    /// deviation, positive, in the file's units); each defaults to the
    /// [`Prior::default`] (1 mm, 1 mrad).
    pub(super) fn prior(&self, doc: &DeTable<'_>, units: Units) -> Result<Prior, InputError> {
        let mut prior = Prior::default();
        let Some((k, v)) = doc.get_key_value("prior") else {
            return Ok(prior);
        };
        let ctx = "[prior]: ";
        let DeValue::Table(t) = v.get_ref() else {
            return Err(self.err(
                k.span(),
                format!(
                    "`prior` must be a table ([prior] with length and angle), found {}",
                    a_type(v.get_ref())
                ),
            ));
        };
        self.check_keys(t, &PRIOR_KEYS, ctx)?;
        for (key, slot, to_si) in [
            (
                "length",
                &mut prior.length,
                Units::length_to_si as fn(&Units, f64) -> f64,
            ),
            ("angle", &mut prior.angle, Units::angle_to_si),
        ] {
            if let Some(v) = t.get(key) {
                let x = self.number(v, key, ctx)?;
                if x <= 0.0 {
                    return Err(self.err(
                        v.span(),
                        format!("{ctx}`{key}` = {x}: the scale of an error must be positive"),
                    ));
                }
                *slot = to_si(&units, x);
            }
        }
        Ok(prior)
    }
}
