//! GPU passes: the light field texture ([`texture`]), the refocus pass ([`refocus`]) and the
//! mesh rasterizer for synthetic light fields ([`raster`]).

pub mod depth;
pub mod raster;
pub mod refocus;
pub mod texture;
