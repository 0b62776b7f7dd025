/* labkit report: fit every table (and wide display math) to the text width before printing;
   a table that would be unreadable shrunk to portrait goes on a landscape page */
function lkFitTable(box) {
  var t = box.querySelector('table'); if (!t) return;
  var w = box.getBoundingClientRect().width;
  t.style.zoom = 1;
  if (!t.classList.contains('lk-verify')) t.classList.add('lk-nowrap');  /* the verification table wraps its lists */          /* natural width: cells unwrapped, headers wrapped at spaces */
  var natural = t.getBoundingClientRect().width;
  t.classList.remove('lk-nowrap');
  var fig = box.closest('figure') || box;
  if (natural * 0.6 > w) {             /* unreadable when shrunk to portrait: turn the page */
    fig.classList.add('lk-landscape');
    w = box.getBoundingClientRect().width;
  }
  if (natural > w) {
    t.style.zoom = Math.max(0.5, 0.96 * (w - 4) / natural);  /* 4 % slack: text metrics change with zoom */
    t.style.width = natural + 'px';      /* keep the measured layout: more room must not unwrap headers */
  }
  if (t.getBoundingClientRect().width > w + 1) { t.classList.add('lk-breakall'); }  /* last resort */
}
function lkFit() {
  document.querySelectorAll('.lk-fit').forEach(lkFitTable);
  document.querySelectorAll('mjx-container[display="true"]').forEach(function (m) {
    var w = m.parentElement.getBoundingClientRect().width, mw = m.getBoundingClientRect().width;
    if (mw > w) { m.style.zoom = Math.max(0.4, (w - 2) / mw); }
  });
  document.body.setAttribute('data-fitted', 'yes');
}
window.addEventListener('load', function () {
  if (window.MathJax && MathJax.startup && MathJax.startup.promise) {
    MathJax.startup.promise.then(lkFit);
  } else { lkFit(); }
});
