// WebXR, basic: an immersive-vr session drawing both eyes from the same patch set and atlas. The
// pose sent to the server is the viewer's (between the eyes); the server shades for that one view.
import {multiply, add, withClipPlanes} from './camera.js';

export function xrAvailable() { return !!navigator.xr; }

export async function startXr(gl, renderer, patches, atlas, sendPose, bounds) {
  if (!(await navigator.xr.isSessionSupported('immersive-vr'))) throw new Error('immersive-vr is not supported here');
  const session = await navigator.xr.requestSession('immersive-vr');
  await gl.makeXRCompatible();
  const layer = new XRWebGLLayer(session, gl);
  session.updateRenderState({baseLayer : layer, depthNear : 0.05, depthFar : 1000});
  const space = await session.requestReferenceSpace('local');
  let frames = 0;
  const onFrame = (time, frame) => {
    session.requestAnimationFrame(onFrame);
    const pose = frame.getViewerPose(space);
    if (!pose) return;
    const m = pose.transform.matrix;
    const eye = [ m[12], m[13], m[14] ];
    const forward = [ -m[8], -m[9], -m[10] ];
    if (frames++ % 2 === 0)
      sendPose(withClipPlanes(
          {eye, target : add(eye, forward), up : [ m[4], m[5], m[6] ], fov : 90, znear : 0, zfar : 0}, bounds()));
    gl.bindFramebuffer(gl.FRAMEBUFFER, layer.framebuffer);
    gl.clearColor(0, 0, 0, 1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    for (const view of pose.views) {
      const vp = layer.getViewport(view);
      const viewProj = multiply(view.projectionMatrix, view.transform.inverse.matrix);
      const p = view.transform.position;
      renderer.draw(patches, atlas(), viewProj, [ p.x, p.y, p.z ], [ vp.x, vp.y, vp.width, vp.height ], false,
                    view.transform.inverse.matrix);
    }
  };
  session.requestAnimationFrame(onFrame);
  return session;
}
