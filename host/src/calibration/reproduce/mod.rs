//! `armcal reproduce`: the worked examples of the seed papers, rebuilt.
//!
//! | module | paper |
//! | --- | --- |
//! | [`mirman_gupta`] | Mirman & Gupta (1992): Tables 2 and 3, the iterative regression on the Table 1 PUMA |
//! | [`kirchner`] | Kirchner, Gurumoorthy & Prinz (1985): the second-order expansion (eq. 2.22) and the series inversion of section 3 (eq. 3.7) beside the iterative regression |

pub mod kirchner;
pub mod mirman_gupta;
