// The stage table: every service's figures from the server's `stats` message (wire.py's
// StatusBoard rows) in the body of the page's table #stats; with `notes`, a last column with
// each service's note. Shared by the live face page (face.js) and the rig console
// (facesynth/app/console/static), whose server serves this file too.
"use strict";

function showStages(services, notes) {
  const body = document.querySelector("#stats tbody");
  body.replaceChildren();
  const fmt = (v) => (v === null ? "–" : v.toFixed(2));
  for (const s of services) {
    const row = document.createElement("tr");
    const cells = [s.service, s.instance, s.status, s.rate_hz.toFixed(1), fmt(s.p50_ms),
      fmt(s.p99_ms), s.received, s.published, s.dropped, s.rejected, s.stale];
    if (notes) cells.push(s.note || "");
    cells.forEach((value, i) => {
      const td = document.createElement("td");
      td.textContent = String(value);
      if (i === 2) td.className = s.status;
      row.appendChild(td);
    });
    body.appendChild(row);
  }
}
