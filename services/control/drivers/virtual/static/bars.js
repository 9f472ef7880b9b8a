// A servo's bar: its name, a track with a mark at neutral and a fill from neutral to where the
// servo is (clamped to low..high), and its value. Shared by the live face page (face.js) and
// the rig console (facesynth/app/console/static), whose server serves this file too.
"use strict";

// Returns { element (the bar's <div class="bar">), show(value) }.
function servoBar(name, low, neutral, high) {
  const element = document.createElement("div");
  element.className = "bar";
  element.innerHTML = '<span class="name"></span><span class="track"><span class="fill"></span>' +
    '<span class="mark"></span></span><span class="value"></span>';
  element.querySelector(".name").textContent = name;
  const span = high - low || 1;
  element.querySelector(".mark").style.left = `${(100 * (neutral - low)) / span}%`;
  const fill = element.querySelector(".fill");
  const text = element.querySelector(".value");
  return {
    element,
    show(value) {
      const v = Math.min(high, Math.max(low, value));
      const a = (100 * (Math.min(v, neutral) - low)) / span;
      const b = (100 * (Math.max(v, neutral) - low)) / span;
      fill.style.left = `${a}%`;
      fill.style.width = `${b - a}%`;
      text.textContent = value.toFixed(0);
    },
  };
}
