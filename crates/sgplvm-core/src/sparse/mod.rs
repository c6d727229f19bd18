//! The sparse shared GP-LVM: per space Titsias' collapsed variational bound with inducing
//! inputs Z shared by all spaces (see `likelihood`), for trainings on every frame of long
//! demonstrations in O(N M²) time and O(N M) memory.

pub(crate) mod likelihood;
