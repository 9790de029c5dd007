//! GPU passes: the light field texture ([`texture`]) and the refocus pass ([`refocus`]).

pub mod refocus;
pub mod texture;
