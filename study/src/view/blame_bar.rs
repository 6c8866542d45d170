//! The blame pane (`swarmfl view LOG --blame blame.json`): each robot's influence as a bar
//! beside the tokens, injected into the page only when a blame report is given, so every
//! other page stays the template's byte for byte.

use crate::blame::BlameReport;

/// Where the pane goes: after the tokens, before the loss.
const ANCHOR: &str = "<div class=\"label\" id=\"lossLabel\">";

/// The pane's drawing: bars up for a positive influence (the robot made the outcome larger),
/// down for a negative one; Byzantine robots red.
const SCRIPT: &str = r##"<script>
(function () {
  var B = JSON.parse(document.getElementById("blameData").textContent);
  var c = document.getElementById("blame"), g = c.getContext("2d"), W = c.width, H = c.height;
  var n = 0, max = 0;
  B.robots.forEach(function (r) { n = Math.max(n, r.robot + 1); max = Math.max(max, Math.abs(r.influence)); });
  if (!(max > 0)) max = 1;
  var bw = (W - 40) / Math.max(n, 1), mid = (H - 20) / 2 + 4;
  g.strokeStyle = "#888"; g.beginPath(); g.moveTo(30, mid); g.lineTo(W - 10, mid); g.stroke();
  g.font = "10px sans-serif";
  B.robots.forEach(function (r) {
    var h = (H / 2 - 20) * r.influence / max, x = 30 + r.robot * bw;
    g.fillStyle = r.byzantine ? "#dc1e1e" : "#28aa3c";
    g.fillRect(x + 2, h > 0 ? mid - h : mid, bw - 4, Math.abs(h));
    g.fillStyle = "#000"; g.fillText(String(r.robot), x + bw / 2 - 4, H - 4);
  });
  g.fillText("+" + max.toExponential(1), 0, 12); g.fillText("-" + max.toExponential(1), 0, H - 14);
})();
</script>
"##;

/// `html` with the blame pane of `report` before the loss pane.
pub(super) fn inject(html: &str, report: &BlameReport) -> anyhow::Result<String> {
    let data = serde_json::to_string(report)?.replace("</", "<\\/");
    let pane = format!(
        "<div class=\"label\" id=\"blameLabel\">blame: influence per robot on {} = {:.4e} at \
         block {} (up: made it larger; from {})</div>\n<canvas id=\"blame\" width=\"560\" \
         height=\"140\"></canvas>\n<script id=\"blameData\" type=\"application/json\">{data}\
         </script>\n{SCRIPT}{ANCHOR}",
        super::html_escape(&report.expr),
        report.outcome,
        report.block,
        super::html_escape(&report.log),
    );
    anyhow::ensure!(
        html.contains(ANCHOR),
        "the viewer's template has no loss pane to put the blame pane before (a bug)"
    );
    Ok(html.replacen(ANCHOR, &pane, 1))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pane lands once, before the loss, with the report's data; the template alone has
    /// none.
    #[test]
    fn the_pane_is_injected_before_the_loss() {
        let report = BlameReport {
            log: "run.swlog".into(),
            expr: "heldout_loss".into(),
            outcome: 1.5,
            block: 7,
            time_s: 70.0,
            robots: Vec::new(),
            counterfactuals: 0,
            wall_s: 0.0,
            cpu_s: 0.0,
        };
        let html = inject(super::super::TEMPLATE, &report).expect("injects");
        assert!(!super::super::TEMPLATE.contains("blameData"));
        assert_eq!(html.matches("id=\"blameData\"").count(), 1);
        assert!(html.find("blameData") < html.find(ANCHOR));
    }
}
