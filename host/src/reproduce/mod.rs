//! `armcal reproduce`: the worked examples of the seed papers, rebuilt.
//!
//! | module | paper |
//! | --- | --- |
//! | [`mirman_gupta`] | Mirman & Gupta (1992): Tables 2 and 3, the iterative regression on the Table 1 PUMA |

pub mod mirman_gupta;
