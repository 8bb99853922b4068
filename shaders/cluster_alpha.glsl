// Alpha MASK in the visibility raster: a masked triangle keeps a pixel only where the base-colour
// alpha (factor x texture; DAG vertices carry no colours) at the pixel's uv is >= alphaCutoff, as
// forward.frag decides it. The uv and the texture level come from the resolve's own reconstruction
// (cluster_surface.glsl: the pixel ray and its right/down neighbours give the uv derivatives), so
// every rasterizer (compute, mesh, indirect, hybrid) and the resolve agree per pixel; a compute
// rasterizer has no dFdx, and the ray differentials give the same level the resolve and hardware
// quads pick. Needs textures[] (set 0, binding 0), shading.glsl and cluster_surface.glsl.

bool maskKeeps(ClusterFrame f, GpuMaterial m, ClusterTriangle tri, vec2 pixelCentre) {
  ClusterSurface s = surfaceAt(f, tri, pixelCentre);
  return baseColor(m, s.uv, vec4(1.0), s.d).a >= m.alphaCutoff;
}

GpuMaterial instanceMaterial(GpuClusterInstance inst) {
  return MaterialRef(push.materialAddress).materials[MeshRef(push.meshAddress).meshes[inst.mesh].material];
}

// Hardware fragment shaders: triangle t of visible entry v at gl_FragCoord.xy (the pixel centre).
// Opaque instances return at the flag test.
bool fragmentAlphaKeeps(uint64_t frameAddress, uint v, uint t, vec2 fragCoord) {
  VisibleCluster vc = VisibleRef(push.visibleAddress).visible[v];
  GpuClusterInstance inst = InstanceRef(push.instanceAddress).instances[vc.instance];
  if ((inst.flags & MIRAGE_INSTANCE_ALPHA_MASK) == 0) return true;
  GpuCluster c = ClusterRef(push.clusterAddress).clusters[vc.cluster];
  ClusterFrame f = FrameRef(frameAddress).frame; // the eye's; stereo: its viewport starts at targetOffsetX
  return maskKeeps(f, instanceMaterial(inst), fetchTriangle(c, inst, t), fragCoord - vec2(f.targetOffsetX, 0.0));
}
