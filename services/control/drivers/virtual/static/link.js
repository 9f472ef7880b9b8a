// The page's WebSocket to its server (/ws on the page's own host): it reconnects by itself
// (after 250 ms, doubling up to 2 s) and sends a ping every 2 s (the server's pong gives the
// round trip). Shared by the live face page (face.js) and the rig console
// (facesynth/app/console/static), whose server serves this file too.
"use strict";

// Connects, and returns the link: open() (whether a message can be sent now) and send(message).
// `state` is the page's window.facesynth (`connects` counts connections); `page` says what
// the page does: status(s) with s "connecting" | "open" | "closed", hello() (the message sent
// first on every connection), text(message), binary(buffer), and optionally closed() (after
// status("closed"), before the next try).
function pageLink(state, page) {
  let socket = null;
  let retryMs = 250;
  const link = {
    open: () => socket !== null && socket.readyState === WebSocket.OPEN,
    send: (message) => socket.send(JSON.stringify(message)),
  };

  function connect() {
    page.status("connecting");
    const scheme = location.protocol === "https:" ? "wss://" : "ws://";
    const ws = new WebSocket(scheme + location.host + "/ws");
    ws.binaryType = "arraybuffer";
    socket = ws;
    ws.onopen = () => {
      state.connects += 1;
      retryMs = 250;
      page.status("open");
      ws.send(JSON.stringify(page.hello()));
    };
    ws.onmessage = (event) => {
      if (typeof event.data === "string") page.text(JSON.parse(event.data));
      else page.binary(event.data);
    };
    ws.onclose = () => {
      if (socket !== ws) return;
      page.status("closed");
      if (page.closed) page.closed();
      setTimeout(connect, retryMs);
      retryMs = Math.min(retryMs * 2, 2000);
    };
  }

  setInterval(() => {
    if (link.open()) link.send({ type: "ping", t: performance.now() });
  }, 2000);
  connect();
  return link;
}
