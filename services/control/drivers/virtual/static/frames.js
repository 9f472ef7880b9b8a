// The performer's frames and landmarks on the page's canvas #frame, as wire.py sends them
// (services/control/drivers/virtual/wire.py: a 4-byte header length, a JSON header, the pixels).
// Shared by the live face page (face.js) and the rig console (facesynth/app/console/static),
// whose server serves this file too. `state` is the page's window.facesynth: its `points` (the
// newest landmarks message) are drawn on each frame and `framesDrawn` counts the frames drawn.
"use strict";

// Returns onFrame(buffer): the newest frame is decoded; any that arrive meanwhile replace each other.
function frameView(state) {
  const frameCanvas = document.getElementById("frame");
  const frameCtx = frameCanvas.getContext("2d");
  let pendingFrame = null;
  let decoding = false;

  async function decodeFrames() {
    decoding = true;
    try {
      while (pendingFrame !== null) {
        const buffer = pendingFrame;
        pendingFrame = null;
        const view = new DataView(buffer);
        const length = view.getUint32(0);
        const header = JSON.parse(new TextDecoder().decode(new Uint8Array(buffer, 4, length)));
        const pixels = new Uint8Array(buffer, 4 + length);
        if (frameCanvas.width !== header.width || frameCanvas.height !== header.height) {
          frameCanvas.width = header.width;
          frameCanvas.height = header.height;
        }
        if (header.encoding === "jpeg") {
          const bitmap = await createImageBitmap(new Blob([pixels], { type: "image/jpeg" }));
          frameCtx.drawImage(bitmap, 0, 0);
          bitmap.close();
        } else {
          const image = frameCtx.createImageData(header.width, header.height);
          for (let i = 0, j = 0; i < pixels.length; i += 3, j += 4) {
            image.data[j] = pixels[i + 2];
            image.data[j + 1] = pixels[i + 1];
            image.data[j + 2] = pixels[i];
            image.data[j + 3] = 255;
          }
          frameCtx.putImageData(image, 0, 0);
        }
        drawPoints(header.width);
        state.framesDrawn += 1;
        document.getElementById("no-frames").hidden = true;
        document.getElementById("frame-info").textContent = `frame ${header.seq}`;
      }
    } catch (error) {
      console.warn("frame not drawn", error);
    } finally {
      decoding = false;
    }
  }

  function drawPoints(width) {
    const p = state.points;
    if (!p || !p.face) return;
    const r = Math.max(1.5, width / 320);
    frameCtx.fillStyle = "#50ff78";
    for (let i = 0; i + 1 < p.ibug68.length; i += 2) {
      frameCtx.beginPath();
      frameCtx.arc(p.ibug68[i], p.ibug68[i + 1], r, 0, 2 * Math.PI);
      frameCtx.fill();
    }
  }

  return (buffer) => {
    pendingFrame = buffer;
    if (!decoding) decodeFrames();
  };
}
