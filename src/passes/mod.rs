//! GPU passes: the light field texture ([`texture`]), the refocus pass ([`refocus`]), the 3-D
//! scene view of the point cloud, cameras and plane ([`scene`]), the window compositor that
//! draws images into panels ([`panel`]) and the mesh rasterizer for synthetic light fields
//! ([`raster`]).

pub mod depth;
pub mod panel;
pub mod raster;
pub mod refocus;
pub mod scene;
pub mod texture;
