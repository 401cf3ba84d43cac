// The scope's colours and fonts (a dark oscilloscope screen), and a uPlot axis in them: shared
// by the single-frame view, the Mega board's view, the roll and cycle plots and the sensor plots.

export const THEME = {
  bg: "#070b0e",
  gridMinor: "rgba(120, 170, 150, 0.08)",
  gridMajor: "rgba(120, 170, 150, 0.20)",
  slotLine: "rgba(255, 255, 255, 0.30)",
  text: "#b9c6c0",
  dim: "#8a9893", // 6.6:1 on the scope's background
  tdm: "#f2d04b",
  select: "#45c8e0",
  sat: "#ff9a1f",
  guard: "#ff3b3b",
  glitch: "#e64dff",
  cursorA: "#7dff72",
  cursorB: "#ff72d2",
  font: "11px ui-monospace, SFMono-Regular, Menlo, Consolas, monospace",
  small: "10px ui-monospace, SFMono-Regular, Menlo, Consolas, monospace",
};

/** A uPlot axis in the scope's colours (the roll and cycle plots share it). */
export const UPLOT_AXIS = {
  stroke: THEME.text,
  grid: { stroke: THEME.gridMajor, width: 1 },
  ticks: { stroke: THEME.gridMajor, width: 1 },
  font: THEME.small,
  labelFont: THEME.small,
};
