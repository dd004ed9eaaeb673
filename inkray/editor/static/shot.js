// inkray edit, a shot: step to the previous and next frame, and mark the entries to check of
// a frame whose annotation was carried from a key (GET /api/shot, POST /api/shot/open).
// An edited frame is saved before stepping: its own annotation file makes it a key, and the
// frames after it are carried from it.
const $ = (id) => document.getElementById(id);

export async function startShot(S, { render, save, dirty, setStatus }) {
  const r = await fetch("/api/shot", { cache: "no-store" });
  if (!r.ok) return;  // editing one annotation file, not a shot
  const shot = await r.json();
  S.shot = shot;
  S.checks = shot.check;
  const i = shot.frames.indexOf(shot.current), n = shot.frames.length;
  $("shot").hidden = false;
  $("shot-frame").textContent = `frame ${shot.current} (${i + 1}/${n})`;
  $("shot-source").textContent = shot.key === null ? "key frame" :
    `carried from ${shot.key}, ${shot.check.length} to check`;
  $("shot-source").title = shot.key === null ? "this frame has its own annotation file" :
    `carried frame by frame from the key ${shot.key} (through frame ${shot.carried_from}); ` +
    "saving this frame makes it a key for the frames after it";
  $("shot-prev").disabled = i <= 0;
  $("shot-next").disabled = i >= n - 1;
  document.body.dataset.frame = shot.current;
  const go = (delta) => step(S, delta, { render, save, dirty, setStatus });
  $("shot-prev").addEventListener("click", () => go(-1));
  $("shot-next").addEventListener("click", () => go(1));
  window.addEventListener("keydown", (e) => {
    if (e.target.closest && e.target.closest("input,select,textarea")) return;
    if (e.ctrlKey || e.metaKey || e.altKey) return;
    if (e.key === ",") go(-1);
    if (e.key === ".") go(1);
  });
  render();
}

async function step(S, delta, { render, save, dirty, setStatus }) {
  const frames = S.shot.frames, k = frames.indexOf(S.shot.current) + delta;
  if (k < 0 || k >= frames.length || S.shot.opening) return;
  S.shot.opening = true;
  try {
    if (dirty()) {
      await save();
      if (S.errors.save) return;  // not saved: stay on this frame with the message
    }
    setStatus(`opening frame ${frames[k]}`);
    const r = await fetch("/api/shot/open", { method: "POST", body: JSON.stringify({ frame: frames[k] }),
                                              headers: { "Content-Type": "application/json" } });
    const answer = await r.json();
    if (!r.ok) {
      S.errors.shot = { error: `frame ${frames[k]}: ${answer.error}`, paths: [] };
      render();
      return;
    }
    location.reload();  // the page starts again on the frame the server now edits
  } finally {
    S.shot.opening = false;
  }
}
