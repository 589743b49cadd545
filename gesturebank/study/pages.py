"""The study's HTML pages, self-contained: CSS and JS inline under the request's nonce (the
app puts it where `{nonce}` stands), videos from this server only, every value escaped."""

from __future__ import annotations

from html import escape
from typing import Any

from gesturebank.study.design import ANSWER_S, READING_S, VIEWS_PER_VIDEO, DesignFile

MUSHRA_SCALE = ("Bad", "Poor", "Fair", "Good", "Excellent")  # ITU-R BS.1534 labels, 20 each

STYLE = """
body { font: 16px/1.4 sans-serif; max-width: 72rem; margin: 1rem auto; padding: 0 1rem; }
video { width: 100%; background: #000; }
.pair { display: grid; grid-template-columns: 1fr 1fr; gap: 1rem; }
.items { display: grid; grid-template-columns: repeat(auto-fill, minmax(18rem, 1fr)); gap: 1rem; }
.item, .ref { border: 1px solid #ccc; padding: .5rem; }
.ref { max-width: 36rem; }
.scale { display: flex; justify-content: space-between; font-size: 12px; color: #555; }
input[type=range] { width: 100%; }
button { font-size: 1.1rem; padding: .4rem 1.2rem; margin-top: 1rem; }
.progress { color: #555; }
dl.who dt { font-weight: bold; }
"""

# Sliders show their value, and the submit button waits until each one has been moved.
SCRIPT = """
(function () {
  var form = document.querySelector('form.trial');
  if (!form) { return; }
  var button = form.querySelector('button');
  var sliders = Array.prototype.slice.call(form.querySelectorAll('input[type=range]'));
  var radios = Array.prototype.slice.call(form.querySelectorAll('input[type=radio]'));
  function check() {
    var ok = sliders.every(function (s) { return s.dataset.moved === '1'; });
    if (radios.length) { ok = ok && radios.some(function (r) { return r.checked; }); }
    button.disabled = !ok;
  }
  sliders.forEach(function (s) {
    s.addEventListener('input', function () {
      s.dataset.moved = '1';
      document.getElementById(s.id + '-v').textContent = s.value;
      check();
    });
  });
  radios.forEach(function (r) { r.addEventListener('change', check); });
  check();
})();
"""


def _page(title: str, body: str) -> str:
    return (
        "<!doctype html><html lang='en'><head><meta charset='utf-8'>"
        "<meta name='viewport' content='width=device-width, initial-scale=1'>"
        f"<title>{escape(title)}</title><style nonce='{{nonce}}'>{STYLE}</style></head>"
        f"<body>{body}<script nonce='{{nonce}}'>{SCRIPT}</script></body></html>"
    )


def _paragraphs(text: str) -> str:
    """The researcher's plain text: blank lines part paragraphs, everything escaped."""
    parts = [p.strip() for p in text.replace("\r\n", "\n").split("\n\n") if p.strip()]
    return "".join(f"<p>{escape(p)}</p>" for p in parts)


def consent_page(*, about: DesignFile, pages: int, minutes: int) -> str:
    """The study as design.toml describes it, with its real length and the estimate's basis."""
    who = [
        ("researcher", "Researcher", about.researcher),
        ("contact", "Contact", about.contact),
        ("ethics", "Ethics approval", about.ethics_reference),
    ]
    facts = "".join(
        f"<dt>{label}</dt><dd id='{key}'>{escape(value)}</dd>" for key, label, value in who if value
    )
    basis = (
        f"estimated from the videos' lengths: each video played {VIEWS_PER_VIDEO} times, "
        f"{ANSWER_S:g} s per answer, and {READING_S / 60:g} minute to read this page and the "
        "instructions"
    )
    return _page(
        "Consent",
        f"<h1 id='title'>{escape(about.title)}</h1>"
        f"<div id='consent-text'>{_paragraphs(about.consent_text)}</div>"
        f"<p id='length'>The study has <b id='pages'>{pages}</b> pages and takes about "
        f"<b id='minutes'>{minutes}</b> minutes ({basis}).</p>"
        f"<h2>Your data</h2><div id='data-use'>{_paragraphs(about.data_use)}</div>"
        + (f"<dl class='who'>{facts}</dl>" if facts else "")
        + "<form method='post' action='/start' id='consent'>"
        "<label><input type='checkbox' name='consent' value='yes' id='agree' required> "
        "I have read the above and agree to take part.</label><br>"
        "<button type='submit' id='start'>Start</button></form>",
    )


def instructions_page(*, token: str, trials: int) -> str:
    return _page(
        "Instructions",
        "<h1>Instructions</h1>"
        "<p>Play each video with its sound. The robot moves its head, arms and hips only; "
        "judge how well those movements go with the speech, not the robot's looks.</p>"
        f"<p>There are {trials} pages. On an <b>A/B</b> page, pick the video whose movements "
        "fit the speech better. On a <b>rating</b> page, a reference is shown on top; rate "
        "every video below it from 0 (bad) to 100 (excellent) with its slider — one of them "
        "may be the reference itself.</p>"
        "<p>If you reload or come back to this address later, you continue where you were.</p>"
        f"<p><a id='begin' href='/p/{escape(token)}/trial'>Begin</a></p>",
    )


def done_page() -> str:
    return _page("Thank you", "<h1 id='done'>Thank you!</h1><p>Your answers are saved.</p>")


def _video(token: str, stimulus: str) -> str:
    src = f"/p/{escape(token)}/video/{escape(stimulus)}"
    poster = f"/p/{escape(token)}/poster/{escape(stimulus)}"
    return f"<video controls preload='metadata' poster='{poster}' src='{src}'></video>"


def _form(token: str, shown: dict[str, Any], step: int, of: int, inner: str) -> str:
    return (
        f"<p class='progress' id='progress'>Page {step} of {of}</p>"
        f"<form class='trial' method='post' action='/p/{escape(token)}/answer'>"
        f"<input type='hidden' name='trial' value='{escape(shown['trial'])}'>{inner}"
        "<p><label>Comments (optional)<br><textarea name='comment' maxlength='500' rows='2' "
        "cols='60'></textarea></label></p>"
        "<button type='submit' id='submit'>Next</button></form>"
    )


def ab_page(*, token: str, shown: dict[str, Any], step: int, of: int, question: str) -> str:
    sides = "".join(
        f"<div class='item'><h2>{label}</h2>{_video(token, sid)}"
        f"<label><input type='radio' name='choice' value='{k}' id='choice-{k}'> {label}</label>"
        "</div>"
        for k, (label, sid) in enumerate(zip(("A", "B"), shown["items"], strict=True))
    )
    inner = f"<h1>{escape(question)}</h1><div class='pair'>{sides}</div>"
    return _page("A/B", _form(token, shown, step, of, inner))


def mushra_page(
    *,
    token: str,
    shown: dict[str, Any],
    step: int,
    of: int,
    reference: str | None,
    questions: dict[str, str],
) -> str:
    scale = "".join(f"<span>{s}</span>" for s in MUSHRA_SCALE)
    items = []
    for k, sid in enumerate(shown["items"]):
        sliders = "".join(
            f"<label for='r-{escape(q)}-{k}'>{escape(text)}</label> "
            f"<output id='r-{escape(q)}-{k}-v'>–</output>"
            f"<input type='range' min='0' max='100' step='1' value='50' "
            f"name='r-{escape(q)}-{k}' id='r-{escape(q)}-{k}'>"
            f"<div class='scale'>{scale}</div>"
            for q, text in questions.items()
        )
        items.append(f"<div class='item'><h2>Video {k + 1}</h2>{_video(token, sid)}{sliders}</div>")
    ref = (
        f"<div class='ref'><h2>Reference</h2>{_video(token, reference)}</div>" if reference else ""
    )
    inner = f"<h1>Rate each video</h1>{ref}<div class='items'>{''.join(items)}</div>"
    return _page("Rating", _form(token, shown, step, of, inner))
