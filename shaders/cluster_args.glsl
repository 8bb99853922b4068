// Indirect arguments of the raster passes, written once for the arguments pass (cluster_args.comp)
// and the flat selection's last workgroup (cluster_select.comp, pass 1). Include after
// cluster_common.glsl.

// (x, y, 1) workgroups for n items of `perGroup`, x below the 65535 limit.
uvec3 splitDispatch(uint n, uint perGroup) {
  uint groups = (n + perGroup - 1) / perGroup;
  return uvec3(min(groups, MIRAGE_CLUSTER_DISPATCH_X), (groups + MIRAGE_CLUSTER_DISPATCH_X - 1) / MIRAGE_CLUSTER_DISPATCH_X, 1);
}

// Raster pass `pass`'s arguments for list `list` (MIRAGE_LIST_*): its entries first..end.
void writeListArgs(uint pass, uint list, uint first, uint end) {
  CounterRef c = CounterRef(push.counterAddress);
  uint n = end - first;
  uvec3 d = splitDispatch(n, 1); // one mesh / compute workgroup per cluster
  c.counters.lists[pass][list].dispatch[0] = d.x;
  c.counters.lists[pass][list].dispatch[1] = d.y;
  c.counters.lists[pass][list].dispatch[2] = 1;
  c.counters.lists[pass][list].first = first;
  c.counters.lists[pass][list].count = n;
  // One instance per cluster, enough vertices for the largest cluster.
  c.counters.lists[pass][list].draw[0] = 3 * MIRAGE_CLUSTER_MAX_TRIANGLES;
  c.counters.lists[pass][list].draw[1] = n;
  c.counters.lists[pass][list].draw[2] = 0;
  c.counters.lists[pass][list].draw[3] = 0;
}

// Pass 1 (index 0): both lists from their start to `listEnds`, and the occlusion passes' dispatches:
// the cull over `candidates` and the late-instance HZB test.
void writePassOneArgs(uint listEnds[2], uint candidates) {
  for (uint list = 0; list < 2; ++list) writeListArgs(0, list, 0, listEnds[list]);
  CounterRef c = CounterRef(push.counterAddress);
  uint n = min(candidates, FrameRef(push.frameAddress).frame.visibleCapacity);
  uvec3 o = splitDispatch(n, MIRAGE_CLUSTER_WORKGROUP);
  c.counters.occlusionArgs[0] = o.x;
  c.counters.occlusionArgs[1] = o.y;
  c.counters.occlusionArgs[2] = 1;
  // One thread per late instance (at most the instance count: one row of groups suffices).
  c.counters.instanceOcclusionArgs[0] = (c.counters.lateInstances + MIRAGE_CLUSTER_WORKGROUP - 1) / MIRAGE_CLUSTER_WORKGROUP;
  c.counters.instanceOcclusionArgs[1] = 1;
  c.counters.instanceOcclusionArgs[2] = 1;
}
