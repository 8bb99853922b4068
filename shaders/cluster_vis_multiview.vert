#version 460
// cluster_vis.vert for stereo by multiview (docs/render.md, "Stereo"): one draw over both eyes'
// layers (view mask 0b11), each eye's clip transform from its frame by gl_ViewIndex.
#extension GL_EXT_multiview : require
#define MIRAGE_VIEW_INDEX gl_ViewIndex
#include "cluster_vis_vert.glsl"
