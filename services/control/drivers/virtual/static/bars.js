// A servo's bar: its name, a track with a mark at neutral and a fill from neutral to where the
// servo is (clamped to low..high), and its value. Shared by the live face page (face.js) and
// the rig console (facesynth/app/console/static), whose server serves this file too.
"use strict";

// Returns { element (the bar's <div class="bar">), show(value, measured?) }: measured, where
// the servo reports itself, is an orange mark (the console; smart bus servos only).
function servoBar(name, low, neutral, high) {
  const element = document.createElement("div");
  element.className = "bar";
  element.innerHTML = '<span class="name"></span><span class="track"><span class="fill"></span>' +
    '<span class="mark"></span><span class="measured" hidden></span></span><span class="value"></span>';
  element.querySelector(".name").textContent = name;
  const span = high - low || 1;
  element.querySelector(".mark").style.left = `${(100 * (neutral - low)) / span}%`;
  const fill = element.querySelector(".fill");
  const text = element.querySelector(".value");
  const measuredMark = element.querySelector(".measured");
  return {
    element,
    // value: the commanded position; measured (optional): where the servo reports itself.
    show(value, measured) {
      const v = Math.min(high, Math.max(low, value));
      const a = (100 * (Math.min(v, neutral) - low)) / span;
      const b = (100 * (Math.max(v, neutral) - low)) / span;
      fill.style.left = `${a}%`;
      fill.style.width = `${b - a}%`;
      const read = typeof measured === "number";
      measuredMark.hidden = !read;
      if (read) {
        const m = Math.min(high, Math.max(low, measured));
        measuredMark.style.left = `${(100 * (m - low)) / span}%`;
      }
      text.textContent = value.toFixed(0) + (read ? ` / ${measured.toFixed(0)}` : "");
    },
  };
}
